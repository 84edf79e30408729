"""Export a fitted model's streaming step for deployment: ONNX, or self-contained C (:doc:`/guide/deploying`).

>>> from tendon_id import zoo
>>> from tendon_id.export import export_model
>>> export_model(zoo.load("model"), "c", "model-c")          # doctest: +SKIP

One step reads a frame (joint angles, actuator-side tensions) and the state the last step
left, and returns the joint-side tensions ``streamer().step`` returns, with the new state
(:mod:`tendon_id.export.interface`).  ``pg-chtc`` and the capstan models whose blocks stream
(``capstan-nonsmooth`` and its family) export to both formats; any other model is a
:class:`~tendon_id.export.spec.ExportError` naming what can be exported.

An export is a folder written whole (a temporary folder renamed into place): ``export.json``,
which describes the step, and ``model.onnx`` or ``PREFIX.c`` with ``PREFIX.h``.  The same model
gives the same bytes.
"""

from __future__ import annotations

import os
from pathlib import Path

from tendon_id import __version__
from tendon_id.atomic import json_text, write_folder_atomic
from tendon_id.checks import check_choice
from tendon_id.errors import ConfigError
from tendon_id.export.c_source import c_files, check_prefix
from tendon_id.export.interface import frame_inputs, frame_outputs, state_entries
from tendon_id.export.run import MANIFEST
from tendon_id.export.spec import EXPORTED_MODELS, CapstanSpec, CascadeSpec, ExportError, step_spec

__all__ = ["DEFAULT_PREFIX", "EXPORTED_MODELS", "FORMATS", "ExportError", "check_out", "export_files", "export_model"]

#: The formats: an ONNX graph of one step, or a C99 source and header.
FORMATS = ("onnx", "c")
#: What the exported C functions, type and files are named after.
DEFAULT_PREFIX = "tendon_model"


def check_out(out: str | os.PathLike) -> Path:
    """Raise ConfigError unless ``out`` may be written as an export folder: new, empty, or an earlier export.

    An earlier export is replaced whole; a folder holding anything else is never touched.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: is a file, not a folder", param="out")
    if out.is_dir() and any(out.iterdir()) and not (out / MANIFEST).is_file():
        raise ConfigError(
            f"{out}: holds files that are not an export (no {MANIFEST}); choose a new or empty folder", param="out"
        )
    return out


def _step_doc(spec: CapstanSpec | CascadeSpec) -> str:
    if isinstance(spec, CapstanSpec):
        return (
            "one frame of the capstan law (paper Eqs. (3)-(6)"
            + (", stick/slip through each guide's play operator" if spec.hysteresis else ", forward slip")
            + "), in float64"
        )
    return (
        "one frame of the PG-CHTC cascade (paper Algorithm 1): unit inputs normalised in float64, "
        "units in float32, the chain of ln T summed in float64"
    )


def export_files(model, fmt: str, prefix: str = DEFAULT_PREFIX) -> dict[str, bytes]:
    """The files of an export of ``model`` to ``fmt``, name -> content, ``export.json`` included.

    Raises
    ------
    ExportError
        For a model that does not export (naming it, the models that do and the formats).
    ConfigError
        For an unknown format or a prefix that is no C identifier.
    """
    fmt = check_choice("format", fmt, FORMATS, what="export format")
    if fmt == "c":
        check_prefix(prefix)
    spec = step_spec(model)
    manifest = {
        "format": fmt,
        "exporter": f"tendon-id {__version__}",
        "model": spec.model,
        "n_modules": spec.n_modules,
        "n_tendons": spec.n_tendons,
        "step": _step_doc(spec),
        "inputs": frame_inputs(spec),
        "outputs": frame_outputs(spec),
        "reset": "at the start of each trajectory, set every state entry to its initial value",
    }
    if fmt == "onnx":
        from tendon_id.export.onnx_capstan import capstan_graph
        from tendon_id.export.onnx_cascade import cascade_graph
        from tendon_id.export.onnx_graph import OPSET

        build = capstan_graph if isinstance(spec, CapstanSpec) else cascade_graph
        files = {"model.onnx": build(spec, __version__).SerializeToString()}
        manifest.update(
            opset=OPSET,
            state=state_entries(spec),
            names="each state entry NAME is an input of the graph and comes back as the output NAME_out",
        )
    else:
        files = {name: text.encode() for name, text in c_files(spec, prefix, __version__).items()}
        manifest["c"] = {
            "prefix": prefix,
            "header": f"{prefix}.h",
            "source": f"{prefix}.c",
            "build": f"cc -O2 -c {prefix}.c  (link the program with -lm)",
            "state": f"{prefix}_state, set up by {prefix}_init and {prefix}_reset",
            "step": f"int {prefix}_step({prefix}_state *, const double *angles, const double *actuator, "
            "double *tensions): 0, or 1 for a frame it refuses (non-finite, or a tension <= 0)",
        }
    files[MANIFEST] = (json_text(manifest, sort_keys=True) + "\n").encode()
    return files


def export_model(model, fmt: str, out: str | os.PathLike, prefix: str = DEFAULT_PREFIX) -> Path:
    """Export ``model``'s streaming step to ``fmt`` (``"onnx"`` or ``"c"``) as the folder ``out``; returns it.

    ``out`` must be new, empty or an earlier export, which is replaced whole (:func:`check_out`).
    See :func:`export_files` for what is raised.
    """
    check_out(out)
    return write_folder_atomic(out, export_files(model, fmt, prefix))
