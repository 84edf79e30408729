"""The data schema of tendon-id: a :class:`Recording` (:doc:`/guide/data`).

A recording is one pandas DataFrame with one row per frame, plus metadata. Units are SI
throughout: time in s, angles in rad, tensions in N.

Columns (``N`` modules, ``k, j = 1..N``, tendon ``i = 1..3``):

========================  ===============================================================
``trajectory``            trajectory id (str); splits are made by trajectory, never by frame
``t``                     time within the trajectory [s], strictly increasing
``theta_{k}_x/_y``        joint angles [rad]
``tension_act_{j}_{i}``   actuator-side tension ``T[1, j, i]`` [N], measured for every set
``tension_joint_{N}_{i}`` terminal joint-side tension [N]: the only label a real robot gives
``tension_joint_{j}_{i}`` joint-side ground truth for ``j < N`` [N]; optional (simulation only),
                          for evaluation, never for fitting (see :meth:`Recording.fitting_view`)
========================  ===============================================================

Other columns are kept and ignored, so users may carry their own signals.

Metadata is stored as JSON under the key ``b"tendon_id"`` of the Parquet key-value schema
metadata, or in a sidecar ``.json`` file beside a CSV file (``x.csv`` -> ``x.json``).

The package is split by job: :mod:`~tendon_id.data.schema` (column names and metadata keys),
:mod:`~tendon_id.data.normalise` (input into canonical form), :mod:`~tendon_id.data.validation`
(one function per rule), :mod:`~tendon_id.data.io` (Parquet, CSV and the sidecar),
:mod:`~tendon_id.data.arrays`, :mod:`~tendon_id.data.select` and :mod:`~tendon_id.data.summary`
(helpers of :mod:`~tendon_id.data.recording`). Imports flow one way, in that order.

This package depends on numpy, pandas and (for Parquet) pyarrow only; never on torch.
"""

from tendon_id.data.columns import DEFAULT_SAMPLE_RATE_HZ
from tendon_id.data.io import META_KEY
from tendon_id.data.recording import Recording
from tendon_id.data.schema import SCHEMA_VERSION, column_names

__all__ = ["SCHEMA_VERSION", "META_KEY", "DEFAULT_SAMPLE_RATE_HZ", "column_names", "Recording"]
