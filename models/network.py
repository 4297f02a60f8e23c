"""The 3DPCNet network (paper section 2.1): hybrid GCN + Transformer encoder, cross-attention
fusion with an adaptive gate, a 6D rotation head and an optional residual head.

Input ``x`` ``(B, 17, 3)``: H36M-17, camera frame, pelvis-centred, scale-normalised by
:func:`pcnet.models.preprocess.normalize_input`. Output ``R_hat`` ``(B, 3, 3)`` maps
canonical to camera (``docs/CONVENTIONS.md``), so the canonical pose is ``x @ R_hat + Delta``
(row vectors; the paper's ``R^T X + Delta``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn
from torch.nn import functional as F

from pcnet.stages.core.conventions import H36M_BONES, L_HIP, PELVIS, R_HIP, THORAX
from pcnet.stages.core.errors import InputError

NUM_JOINTS = 17
#: Frames the network's input may be expressed in (:class:`PCNetConfig` ``input_frame``).
INPUT_FRAMES = ("camera", "body")


@dataclass(frozen=True)
class PCNetConfig:
    """Architecture; the defaults are the paper's (section 2.2.2, implementation details)."""

    hidden: int = 256
    output: int = 384
    gcn_layers: int = 3
    transformer_layers: int = 2
    heads: int = 8
    feedforward: int = 512
    dropout: float = 0.1
    residual: bool = True
    # "camera": the paper's input (camera-frame poses); "body": the same poses first
    # expressed in a frame fixed to the body (:func:`body_frame`), pcnet's addition that
    # makes the prediction exactly equivariant to camera rotation.
    input_frame: str = "camera"

    def __post_init__(self) -> None:
        # Sizes torch would otherwise reject with a traceback deep inside nn.MultiheadAttention.
        for name in ("hidden", "output", "heads", "feedforward"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                raise InputError(f"[model] field {name!r}: expected an integer >= 1, got {getattr(self, name)!r}")
        for name in ("gcn_layers", "transformer_layers"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 0:
                raise InputError(f"[model] field {name!r}: expected an integer >= 0, got {getattr(self, name)!r}")
        if self.hidden % self.heads:
            raise InputError(f"[model] field 'heads': expected a divisor of hidden ({self.hidden}), got {self.heads}")
        if not 0 <= self.dropout < 1:
            raise InputError(f"[model] field 'dropout': expected a value in [0, 1), got {self.dropout}")
        if self.input_frame not in INPUT_FRAMES:
            raise InputError(f"[model] field 'input_frame': expected one of {INPUT_FRAMES}, got {self.input_frame!r}")

    def to_dict(self) -> dict:
        return asdict(self)


def rotation_6d_to_matrix(d6: torch.Tensor) -> torch.Tensor:
    """6D ``(..., 6)`` -> rotation matrix ``(..., 3, 3)`` by Gram-Schmidt (Zhou et al. 2019).

    The 6D vector holds the first two columns ``[a1, a2]``; ``R = [b1 b2 b3]`` with
    ``b1 = a1/|a1|``, ``b2 = normalize(a2 - (b1.a2) b1)``, ``b3 = b1 x b2``. The cross
    product is written out because ONNX has no Cross operator (onnx/onnx#2683). Same
    convention as :func:`pcnet.stages.core.rotations.rotation_6d_to_matrix`.
    """
    return _orthonormal_columns(d6[..., 0:3], d6[..., 3:6])


def _orthonormal_columns(a1: torch.Tensor, a2: torch.Tensor) -> torch.Tensor:
    """``[b1 b2 b1 x b2]`` by Gram-Schmidt of ``a1``, ``a2`` ``(..., 3)``; the cross product
    is written out because ONNX has no Cross operator (onnx/onnx#2683)."""
    b1 = F.normalize(a1, dim=-1, eps=1e-6)
    b2 = F.normalize(a2 - (b1 * a2).sum(-1, keepdim=True) * b1, dim=-1, eps=1e-6)
    x1, y1, z1 = b1.unbind(-1)
    x2, y2, z2 = b2.unbind(-1)
    b3 = torch.stack([y1 * z2 - z1 * y2, z1 * x2 - x1 * z2, x1 * y2 - y1 * x2], dim=-1)
    return torch.stack([b1, b2, b3], dim=-1)


def body_frame(x: torch.Tensor) -> torch.Tensor:
    """A frame fixed to the body by the pose alone, ``(B, 3, 3)`` body->input rotations:
    columns = the spine axis (pelvis -> thorax), the hip line (right hip - left hip) made
    perpendicular to it, and their cross product. ``x`` ``(B, 17, 3)`` pelvis-centred
    H36M-17. Rotating the camera rotates this frame alike, so ``x @ body_frame(x)`` (the
    pose in body coordinates) is the same from every camera."""
    return _orthonormal_columns(x[:, THORAX] - x[:, PELVIS], x[:, R_HIP] - x[:, L_HIP])


def skeleton_adjacency() -> torch.Tensor:
    """``A0``: the H36M-17 bone graph with self-loops, ``(17, 17)`` float32."""
    A = torch.eye(NUM_JOINTS)
    for a, b in H36M_BONES:
        A[a, b] = A[b, a] = 1.0
    return A


def _sym_normalize(A: torch.Tensor) -> torch.Tensor:
    d = A.sum(-1).clamp_min(1e-6).rsqrt()
    return d[:, None] * A * d[None, :]


class AdaptiveGCN(nn.Module):
    """GCN branch on ``A = sigmoid(alpha) A0 + (1 - sigmoid(alpha)) A_learned`` (paper 2.1.1);
    ``A_learned`` is symmetric and non-negative (sigmoid of a symmetrised parameter), both
    graphs symmetrically degree-normalised."""

    def __init__(self, cfg: PCNetConfig):
        super().__init__()
        self.register_buffer("A0", _sym_normalize(skeleton_adjacency()))
        self.alpha = nn.Parameter(torch.tensor(2.0))
        self.learned = nn.Parameter(torch.zeros(NUM_JOINTS, NUM_JOINTS))
        self.embed = nn.Linear(3, cfg.hidden)
        self.layers = nn.ModuleList(nn.Linear(cfg.hidden, cfg.hidden) for _ in range(cfg.gcn_layers))
        self.norms = nn.ModuleList(nn.LayerNorm(cfg.hidden) for _ in range(cfg.gcn_layers))
        self.drop = nn.Dropout(cfg.dropout)

    def learned_adjacency(self) -> torch.Tensor:
        return _sym_normalize(torch.sigmoid(0.5 * (self.learned + self.learned.T)))

    def adjacency(self) -> torch.Tensor:
        g = torch.sigmoid(self.alpha)
        return g * self.A0 + (1 - g) * self.learned_adjacency()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Per-joint features ``(B, 17, hidden)`` float32 of normalised poses ``x``
        ``(B, 17, 3)`` (as :meth:`PCNet.forward` takes them): residual GCN layers
        ``h + Dropout(GELU(LayerNorm(A W h)))`` on the adaptive graph (paper 2.1.1)."""
        A = self.adjacency()
        h = self.embed(x)
        for lin, norm in zip(self.layers, self.norms):
            h = h + self.drop(F.gelu(norm(torch.matmul(A, lin(h)))))
        return h


class PCNet(nn.Module):
    """3DPCNet. ``forward(x)`` -> ``(R_hat (B,3,3), delta (B,17,3))``; with
    ``return_aux=True`` also a dict of tensors the regularisers need. With
    ``input_frame = "body"`` the encoder reads ``x @ body_frame(x)`` and ``R_hat`` is the
    predicted canonical->body rotation composed with body->camera, so inputs, outputs and
    losses keep the camera-frame meaning of the paper."""

    def __init__(self, cfg: PCNetConfig = PCNetConfig()):
        super().__init__()
        self.cfg = cfg
        H = cfg.hidden
        self.gcn = AdaptiveGCN(cfg)
        self.embed = nn.Linear(3, H)
        self.pos = nn.Parameter(0.02 * torch.randn(1, NUM_JOINTS, H))
        layer = nn.TransformerEncoderLayer(
            H, cfg.heads, cfg.feedforward, cfg.dropout, activation="gelu", batch_first=True, norm_first=True
        )
        self.transformer = nn.TransformerEncoder(layer, cfg.transformer_layers, enable_nested_tensor=False)
        self.cross = nn.MultiheadAttention(H, cfg.heads, dropout=cfg.dropout, batch_first=True)
        # Flattened (not pooled) joints keep left/right identity, which decides the heading.
        self.proj_fused = nn.Linear(NUM_JOINTS * H, cfg.output)
        self.proj_gcn = nn.Linear(NUM_JOINTS * H, cfg.output)
        self.proj_trans = nn.Linear(NUM_JOINTS * H, cfg.output)
        self.gate = nn.Sequential(nn.Linear(2 * cfg.output, H), nn.GELU(), nn.Linear(H, 2))
        self.rot_head = nn.Sequential(nn.Linear(cfg.output, H), nn.GELU(), nn.Linear(H, 6))
        self.res_head = (
            nn.Sequential(nn.Linear(cfg.output, H), nn.GELU(), nn.Linear(H, NUM_JOINTS * 3)) if cfg.residual else None
        )
        if self.res_head is not None:
            nn.init.zeros_(self.res_head[-1].weight)
            nn.init.zeros_(self.res_head[-1].bias)

    def forward(self, x: torch.Tensor, return_aux: bool = False):
        """``x`` ``(B, 17, 3)`` float32: H36M-17 camera-frame poses (OpenCV axes),
        pelvis-centred and scale-normalised by :func:`pcnet.models.preprocess.normalize_input`.
        Returns ``R_hat`` ``(B, 3, 3)`` canonical->camera (Gram-Schmidt of the 6D head, paper
        2.1.2) and the residual ``delta`` ``(B, 17, 3)`` in the normalised units (zeros without
        a residual head); with ``return_aux`` also ``{"attention": (B, heads, 17, 17) or None,
        "gate": (B, 2)}``."""
        B = body_frame(x) if self.cfg.input_frame == "body" else None
        if B is not None:
            x = x @ B
        h_gcn = self.gcn(x)
        h_trans = self.transformer(self.embed(x) + self.pos)
        attended, attn = self.cross(
            h_gcn, h_trans, h_trans, need_weights=return_aux, average_attn_weights=False
        )
        z_gcn = self.proj_gcn(h_gcn.flatten(1))
        z_trans = self.proj_trans(h_trans.flatten(1))
        z_fused = self.proj_fused(attended.flatten(1))
        w = torch.softmax(self.gate(torch.cat([z_gcn, z_trans], -1)), -1)
        z = z_fused + w[:, 0:1] * z_gcn + w[:, 1:2] * z_trans
        R = rotation_6d_to_matrix(self.rot_head(z))
        if B is not None:  # canonical -> body, then body -> camera
            R = B @ R
        if self.res_head is not None:
            delta = self.res_head(z).reshape(-1, NUM_JOINTS, 3)
        else:
            delta = torch.zeros_like(x)
        if not return_aux:
            return R, delta
        return R, delta, {"attention": attn, "gate": w}
