"""Pure-numpy physics of tendon transmission through cable guides.

Every function here is vectorised over arbitrary leading axes (time, sets,
tendons) and knows nothing about recordings, files or torch.  Units are SI:
tensions in N, angles in rad, speeds in m/s, times in s.

Equation numbers refer to the PG-CHTC paper (``shared/seed/pg-chtc-paper.txt``).
"""

from friction_models.bending_stiffness import SLACK_FLOOR_N, bending_loss, edges_with_loss
from friction_models.capstan import capstan_exponent, capstan_ratio
from friction_models.contact_gate import dead_zone_wrap, hard_contact_gate, smooth_contact_gate
from friction_models.friction_drift import run_in_wear_factor
from friction_models.guide_wear import guide_wear_factors
from friction_models.load_cell import first_order_inverse, first_order_lowpass, gain_offset, shifted_read
from friction_models.maxwell_slip import maxwell_slip, maxwell_slip_output
from friction_models.mu_laws import affine_cosine_mu, constant_mu, speed_factor, velocity_dependent_mu
from friction_models.play_operator import PlayResult, play_operator, play_operator_edges, slip_state
from friction_models.viscoelastic import viscoelastic_lag

__all__ = [
    "SLACK_FLOOR_N",
    "PlayResult",
    "affine_cosine_mu",
    "bending_loss",
    "capstan_exponent",
    "capstan_ratio",
    "constant_mu",
    "dead_zone_wrap",
    "edges_with_loss",
    "first_order_inverse",
    "first_order_lowpass",
    "gain_offset",
    "guide_wear_factors",
    "hard_contact_gate",
    "maxwell_slip",
    "maxwell_slip_output",
    "play_operator",
    "play_operator_edges",
    "run_in_wear_factor",
    "shifted_read",
    "slip_state",
    "smooth_contact_gate",
    "speed_factor",
    "velocity_dependent_mu",
    "viscoelastic_lag",
]
