"""The ``tendon-id`` command line (:doc:`/cli`).

Exit codes: 0 ok, 2 bad input (one line naming the file or option), 1 internal error, 130
interrupted (Ctrl-C: one line saying where the work stopped and which whole files it wrote).

The long commands (fit, calibrate, identifiability, diagnose, benchmark, demo) check their
options, outputs and optional dependencies before the long part starts, name their phases for
the interrupt's message (:func:`tendon_id.progress.stage`), and hold a Ctrl-C over a group of
output files that belong together (:func:`tendon_id.atomic.hold_interrupt`).

Every command writes its
JSON to ``--json PATH``, or prints it alone on stdout with ``--json -``, its other lines then on
stderr (:class:`~tendon_id.cli.common.JsonOutput`). ``tendon-id --version`` prints the version.

The lists in the help texts (models, benchmarks, protocols, effects) come from their
registries. Each command imports what it runs inside its body, so that ``--help`` and a
mistyped option answer at once instead of after loading torch. The commands live by job:
:mod:`~tendon_id.cli.data` (simulate, info), :mod:`~tendon_id.cli.models` (fit, evaluate,
calibrate), :mod:`~tendon_id.cli.deploy` (export), :mod:`~tendon_id.cli.bench` (benchmark),
:mod:`~tendon_id.cli.analyses` (identifiability, diagnose) and :mod:`~tendon_id.cli.demo`;
:mod:`~tendon_id.cli.app` runs them.
"""

# isort: off
# Each module registers its commands, in the order --help lists them.
from tendon_id.cli import data, models, deploy, bench, analyses, demo  # noqa: F401
from tendon_id.cli.app import app, main

# isort: on

__all__ = ["app", "main"]
