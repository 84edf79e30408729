"""Plain-text rendering of a recording summary for ``tendon-id info``."""

from __future__ import annotations


def format_summary(s: dict, name: str) -> str:
    """Render :meth:`tendon_id.data.Recording.summary` as a few aligned lines."""
    r = s.get("ranges", {})
    truth = s.get("truth", {})
    inter = truth.get("intermediate_joints") or []
    lines = [
        f"recording     {name}",
        f"modules       {s['n_modules']}",
        f"frames        {s['n_frames']}  ({s.get('duration_s', 0):.1f} s at {s.get('sample_rate_hz', 0):g} Hz)",
        f"trajectories  {s['n_trajectories']}",
        f"protocol      {s.get('protocol') or '-'}",
        f"recipe        {s.get('recipe') or '-'}   seed {s.get('seed') if s.get('seed') is not None else '-'}",
        f"effects       {', '.join(s.get('effects') or []) or 'none'}",
    ]
    for key, label, unit in (
        ("angle_deg", "angles", "deg"),
        ("actuator_n", "actuator", "N"),
        ("terminal_n", "terminal", "N"),
    ):
        if key in r:
            lo, hi = r[key]["min"], r[key]["max"]
            lines.append(f"{label:<13} {lo:9.2f} .. {hi:9.2f} {unit}")
    lines.append(
        "truth         terminal joint side: yes; intermediate joint sides: "
        + (f"yes (joints {inter[0]}..{inter[-1]})" if truth.get("intermediate") and inter else "no")
    )
    return "\n".join(lines)
