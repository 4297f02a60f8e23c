"""The documentation the outputs cite ships with the package: `pcnet docs`."""

from __future__ import annotations

import fnmatch
import re
import subprocess
import sys
import tomllib

from click.testing import CliRunner
from conftest import FIXTURES, ROOT

from pcnet.pipeline.cli import main
from pcnet.pipeline.doc_pages import docs_folder, find_page, pages

CITED = re.compile(r"docs/([\w/]+)\.md")


def test_every_page_the_outputs_and_help_cite_ships_and_pcnet_docs_prints_it(tmp_path):
    """A user trial's pip install had none of the docs/... pages that --help, report.md and
    kinematics_columns.csv cite. Each cited page resolves to a shipped page, one the wheel's
    package data takes (pyproject.toml), and `pcnet docs` prints it as cited."""
    runner = CliRunner()
    out = tmp_path / "o"
    res = runner.invoke(main, ["run", "--lifter", "motionbert", "--lifter-output",
                               str(FIXTURES / "boxing_X3D_f000-059.npy"), "--keypoints2d",
                               str(FIXTURES / "boxing_alphapose_f000-059.json"), "--keypoints2d-format", "alphapose",
                               "--fps", "30", "--height", "1.75", "--no-recording", "--out", str(out)])
    assert res.exit_code == 0, res.output
    texts = [res.output, (out / "report.md").read_text(), (out / "kinematics_columns.csv").read_text()]
    texts += [runner.invoke(main, [name, "--help"]).output for name in main.commands]
    cited = {m for text in texts for m in CITED.findall(text)}
    assert {"joint_angles", "guide/limits", "outputs", "up_model"} <= cited, cited
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["pcnet.docs"]
    for name in sorted(cited):
        found, file = find_page(f"docs/{name}.md#a-section")
        assert found == name and any(fnmatch.fnmatch(f"{name}.md", g) for g in globs), name
        shown = runner.invoke(main, ["docs", f"docs/{name}.md"])
        assert shown.exit_code == 0 and shown.output == file.read_text(encoding="utf-8")


def test_pcnet_docs_lists_the_pages_and_refuses_an_unknown_one_in_one_line():
    runner = CliRunner()
    listed = runner.invoke(main, ["docs"])
    assert listed.exit_code == 0
    assert re.search(r"^guide/limits +Limits \(measured\)$", listed.output, re.M), listed.output
    assert len(pages()) == len([line for line in listed.output.splitlines() if line and not line.startswith("pcnet")])
    assert find_page("limits")[0] == "guide/limits"  # a file name no other page has
    # a decision by its number, as the outputs cite them ("decision 0090"; an audit could not follow one)
    assert find_page("0090")[0].startswith("decisions/0090-") and find_page("90") == find_page("0090")
    assert docs_folder().samefile(ROOT / "docs")  # this checkout's pages (an editable install)
    refused = runner.invoke(main, ["docs", "limts"])
    assert refused.exit_code == 1 and len(refused.output.strip().splitlines()) == 1
    assert "got no page 'limts' (limts: limits?)" in refused.output
    # the site's API pages are rendered docstrings: pydoc shows them (a developer trial looked here)
    api = runner.invoke(main, ["docs", "api/pipeline"])
    assert api.exit_code == 1 and api.output.strip().endswith("python -m pydoc pcnet.pipeline"), api.output


def test_a_reader_that_stops_reading_gets_no_error_line():
    """`pcnet docs PAGE | head` (a trial's pipe closed early) printed "Error: [Errno 32] Broken
    pipe"; the reader stopping is not an error of the input: no line on stderr."""
    proc = subprocess.Popen([sys.executable, "-m", "pcnet.pipeline.entry", "docs", "CONVENTIONS"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # before pcnet has written anything (it imports first)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 1 and err == "", err
