"""3DPCNet's composite loss (paper section 2.2.1, eq. 2):
``L = w_p L_pose + w_r L_rot + w_c L_cyc + w_perc L_perc + w_reg L_reg``.

All poses are row-vector arrays ``(B, 17, 3)`` in normalised units; ``R`` maps canonical to
camera, so ``X_c_hat = X @ R_hat + Delta`` and the cycle is ``X_c_hat @ R_hat^T ~ X``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import roma
import torch

from pcnet.stages.core.conventions import H36M_BONES

_BONES = torch.tensor(H36M_BONES)
# Pairs of bones sharing a joint (parent bone, child bone), whose angle L_perc preserves.
_BONE_PAIRS = torch.tensor(
    [(i, j) for i, (_, c) in enumerate(H36M_BONES) for j, (p, _) in enumerate(H36M_BONES) if p == c]
)


@dataclass(frozen=True)
class LossWeights:
    """The paper's weights (section 2.2.2); ``reg`` is "small" there, unspecified."""

    pose: float = 1.0
    rot: float = 1.0
    cyc: float = 0.25
    perc: float = 0.15
    reg: float = 0.01
    reg_delta: float = 1.0
    reg_topology: float = 0.1
    reg_diversity: float = 0.1

    def to_dict(self) -> dict:
        return asdict(self)


def _bone_vectors(X: torch.Tensor) -> torch.Tensor:
    return X[:, _BONES[:, 1]] - X[:, _BONES[:, 0]]


def perceptual_loss(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """The paper's perceptual loss L_perc (3DPCNet paper, "Training and Optimization"): bone-length MSE plus MSE
    of the cosines between adjacent bones (joint angles).

    Args:
        pred, target: ``(B, 17, 3)`` H36M-17 poses (canonical frame, normalised units).

    Returns:
        a scalar tensor.
    """
    bp, bt = _bone_vectors(pred), _bone_vectors(target)
    lengths = (bp.norm(dim=-1) - bt.norm(dim=-1)).pow(2).mean()
    up = torch.nn.functional.normalize(bp, dim=-1, eps=1e-6)
    ut = torch.nn.functional.normalize(bt, dim=-1, eps=1e-6)
    a, b = _BONE_PAIRS[:, 0], _BONE_PAIRS[:, 1]
    cos_p = (up[:, a] * up[:, b]).sum(-1)
    cos_t = (ut[:, a] * ut[:, b]).sum(-1)
    return lengths + (cos_p - cos_t).pow(2).mean()


def attention_diversity(attn: torch.Tensor) -> torch.Tensor:
    """Mean pairwise cosine similarity between heads' attention maps ``(B, heads, Q, K)``:
    low when heads attend differently. pcnet's Transformer layers use fused attention, so
    the term is taken on the fusion cross-attention's heads."""
    a = torch.nn.functional.normalize(attn.flatten(2), dim=-1)
    sim = a @ a.transpose(1, 2)  # (B, heads, heads)
    h = sim.shape[-1]
    off = sim.sum((-1, -2)) - sim.diagonal(dim1=-2, dim2=-1).sum(-1)
    return (off / (h * (h - 1))).mean()


#: roma's asin clamping for the geodesic loss (finite gradients).
ROT_CLAMP = 1.0 - 1e-6


def composite_loss(model, x, R_hat, delta, aux, R_true, canon_true, w: LossWeights):
    """Total loss and a dict of its (detached) parts.

    Args:
        x: ``(B, 17, 3)`` normalised camera-frame input.
        R_hat, delta: network outputs; R_true ``(B, 3, 3)`` canonical->camera;
        canon_true: ``(B, 17, 3)`` canonical target in the same normalised units.
    """
    canon_hat = x @ R_hat + delta
    l_pose = (canon_hat - canon_true).pow(2).sum(-1).mean()
    # asin is clamped below 1 so a prediction at 180 deg (common at initialisation when the
    # input is in the body frame and every pose looks alike) has a finite gradient.
    l_rot = roma.rotmat_geodesic_distance(R_hat, R_true, clamping=ROT_CLAMP).mean()
    l_cyc = (canon_hat @ R_hat.transpose(1, 2) - x).pow(2).sum(-1).mean()
    l_perc = perceptual_loss(canon_hat, canon_true)
    gcn = model.gcn
    l_topo = (gcn.learned_adjacency() - gcn.A0).abs().mean()
    l_div = attention_diversity(aux["attention"]) if aux.get("attention") is not None else x.new_zeros(())
    l_reg = w.reg_delta * delta.pow(2).sum(-1).mean() + w.reg_topology * l_topo + w.reg_diversity * l_div
    total = w.pose * l_pose + w.rot * l_rot + w.cyc * l_cyc + w.perc * l_perc + w.reg * l_reg
    parts = {"total": total, "pose": l_pose, "rot": l_rot, "cyc": l_cyc, "perc": l_perc, "reg": l_reg}
    return total, {k: float(v.detach()) for k, v in parts.items()}

