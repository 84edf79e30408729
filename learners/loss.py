"""The PG-CHTC loss, paper Eqs. (11)–(15), in the log domain, on the terminal set's chain."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor


@dataclass(frozen=True)
class LossWeights:
    """``lambda`` (prior), ``lambda_s`` (smoothness) and ``eta_w`` (kernel sharpness); paper defaults."""

    lam: float = 1.0
    lam_s: float = 0.1
    eta_w: float = 2.0


def pgchtc_loss(
    log_terminal_hat: Tensor,
    log_terminal: Tensor,
    log_ratio: Tensor,
    log_ratio_phys: Tensor,
    alpha: Tensor,
    weights: LossWeights,
    mask: Tensor | None = None,
) -> tuple[Tensor, dict[str, float]]:
    """Mean over frames of ``L_data + lambda L_phys + lambda_s L_smooth``.

    Parameters
    ----------
    log_terminal_hat, log_terminal : Tensor, shape (..., n)
        ``ln T_hat[N, N]`` and the label ``ln T[N, N]`` (Eq. (12)), ``n`` tendons (summed over).
    log_ratio : Tensor, shape (..., N-1, n)
        ``ln r_data`` of the terminal set at every guide.
    log_ratio_phys : Tensor, shape (..., N-1, n)
        Capstan prior ``ln r_phys = -mu(alpha) alpha`` (Eqs. (9), (13)).
    alpha : Tensor, shape (..., N-1)
        Wraps, for the smoothness kernel ``w_k = exp(-eta_w (alpha_k - alpha_{k+1})^2)`` (Eq. (15)).
    weights : LossWeights
    mask : Tensor of bool, shape (...), optional
        Frames that count.

    Returns
    -------
    loss : Tensor (scalar)
    parts : dict
        Mean of each term, for logging.
    """
    data = ((log_terminal_hat - log_terminal) ** 2).sum(-1)
    phys = ((log_ratio - log_ratio_phys) ** 2).sum((-1, -2))
    w = torch.exp(-weights.eta_w * (alpha[..., :-1] - alpha[..., 1:]) ** 2)
    smooth = (w * ((log_ratio[..., :-1, :] - log_ratio[..., 1:, :]) ** 2).sum(-1)).sum(-1)
    total = data + weights.lam * phys + weights.lam_s * smooth
    if mask is not None:
        m = mask.to(total.dtype)
        n = m.sum().clamp_min(1.0)
        reduce = lambda t: (t * m).sum() / n  # noqa: E731
    else:
        reduce = torch.mean
    loss = reduce(total)
    with torch.no_grad():
        parts = {"data": float(reduce(data)), "phys": float(reduce(phys)), "smooth": float(reduce(smooth))}
    return loss, parts
