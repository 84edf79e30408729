"""tendon-id: physics-informed identification of tendon transmissions in snake robots.

The paper implemented here is PG-CHTC (``shared/seed/pg-chtc-paper.txt``).
"""

__version__ = "0.1.0"
