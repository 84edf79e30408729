"""tendon-id: physics-informed identification of tendon transmissions in snake robots.

The method implemented here is PG-CHTC, the physics-guided cable-hole transmission cascade of
"Physics-Guided Learning for Tendon State Estimation of Cable-Driven Hyper-Redundant Robots"
(IEEE RA-L, 2026); :doc:`/guide/architecture` maps the code.
"""

__version__ = "0.1.0"
