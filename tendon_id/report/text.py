"""Plain-text rendering of a recording summary for ``tendon-id info``."""

from __future__ import annotations


def format_summary(s: dict, name: str) -> str:
    """Render :meth:`tendon_id.data.Recording.summary` as a few aligned lines."""
    if s.get("kind") == "passage":
        return format_passage_summary(s, name)
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


def format_passage_summary(s: dict, name: str) -> str:
    """Render :meth:`tendon_id.data.passage.PassageRecording.summary` as a few aligned lines."""
    wrap = s.get("wrap_angle")
    lines = [
        f"passage       {name}",
        f"quantity      {s['quantity']} (an {'antagonistic pair' if s['quantity'] == 'torque' else 'single tendon'})",
        f"frames        {s['n_frames']}  ({s['duration_s']:.1f} s at {s['sample_rate_hz']:g} Hz)",
        f"trajectories  {s['n_trajectories']}",
        f"wrap angle    {'inferred (the capstan exponent is fitted)' if wrap is None else f'{wrap:.4g} rad'}",
    ]
    for key, r in s.get("ranges", {}).items():
        label, _, unit = key.rpartition("_")
        lines.append(f"{label:13s} {r['min']:.4g} .. {r['max']:.4g} {unit.replace('*', ' ')}")
    return "\n".join(lines)
