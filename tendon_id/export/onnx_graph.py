"""A small builder of ONNX graphs with deterministic names: the same calls give the same bytes.

Why not ``torch.onnx.export``: its default exporter (``dynamo=True`` since torch 2.9) needs
``onnxscript`` and traces a torch module, and the older TorchScript exporter is deprecated; the
streaming step's ring bookkeeping is Python control flow that neither traces cleanly, and the
capstan laws are numpy, not torch.  Writing the step's few dozen operator types with
:mod:`onnx.helper` serves both families, offline, and every node and initializer is named
by a counter, so an export is reproducible to the byte.
"""

from __future__ import annotations

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

#: The operator set the graphs are written for: LayerNormalization needs 17.
OPSET = 17
F32, F64, I64 = TensorProto.FLOAT, TensorProto.DOUBLE, TensorProto.INT64
DTYPE_NAMES = {F32: "float32", F64: "float64", I64: "int64"}


class Graph:
    """Nodes, initializers, inputs and outputs of one graph, named in the order they are made."""

    def __init__(self):
        self.nodes: list = []
        self.initializers: list = []
        self.inputs: list = []
        self.outputs: list = []
        self._count = 0
        self._consts: dict[tuple, str] = {}

    def _name(self, stem: str) -> str:
        self._count += 1
        return f"{stem}_{self._count}"

    # ---- values ------------------------------------------------------------------------
    def input(self, name: str, dtype: int, shape: list[int]) -> str:
        self.inputs.append(helper.make_tensor_value_info(name, dtype, shape))
        return name

    def output(self, name: str, value: str, dtype: int, shape: list[int]) -> None:
        """Graph output ``name`` equal to ``value`` (through an Identity, so that the name is the caller's)."""
        self.nodes.append(helper.make_node("Identity", [value], [name], name=f"out_{name}"))
        self.outputs.append(helper.make_tensor_value_info(name, dtype, shape))

    def const(self, array: np.ndarray, name: str | None = None) -> str:
        """An initializer holding ``array`` (its dtype kept); small equal constants are stored once."""
        array = np.ascontiguousarray(array)
        key = None
        if name is None and array.size <= 16:
            key = (array.dtype.str, array.shape, array.tobytes())
            if key in self._consts:
                return self._consts[key]
        name = name or self._name("const")
        self.initializers.append(numpy_helper.from_array(array, name))
        if key is not None:
            self._consts[key] = name
        return name

    def f64(self, *values: float) -> str:
        return self.const(np.array(values, dtype=np.float64))

    def f32(self, *values: float) -> str:
        return self.const(np.array(values, dtype=np.float32))

    def i64(self, *values: int) -> str:
        return self.const(np.array(values, dtype=np.int64))

    # ---- operators ---------------------------------------------------------------------
    def op(self, op_type: str, *inputs: str, **attrs) -> str:
        """One node with one output; returns the output's name."""
        out = self._name(op_type.lower())
        self.nodes.append(helper.make_node(op_type, list(inputs), [out], name=f"n_{out}", **attrs))
        return out

    def ops(self, op_type: str, inputs: list[str], n_out: int, **attrs) -> list[str]:
        """One node with ``n_out`` outputs."""
        outs = [self._name(op_type.lower()) for _ in range(n_out)]
        self.nodes.append(helper.make_node(op_type, inputs, outs, name=f"n_{outs[0]}", **attrs))
        return outs

    def slice(self, x: str, starts: list[int], ends: list[int], axes: list[int]) -> str:
        return self.op("Slice", x, self.i64(*starts), self.i64(*ends), self.i64(*axes))

    def rows(self, x: str, start: int, stop: int) -> str:
        """``x[start:stop]`` along the first axis."""
        return self.slice(x, [start], [stop], [0])

    def reshape(self, x: str, shape: list[int]) -> str:
        return self.op("Reshape", x, self.i64(*shape))

    def linear(self, x: str, weight: str, bias: str) -> str:
        """``x @ weight + bias`` with ``weight`` stored (in, out), as the streaming engines apply it."""
        return self.op("Add", self.op("MatMul", x, weight), bias)

    def gelu(self, x: str) -> str:
        """The exact GELU of torch's default, ``x * 0.5 * (1 + erf(x / sqrt 2))`` (float32)."""
        erf = self.op("Erf", self.op("Mul", x, self.f32(np.sqrt(0.5))))
        return self.op("Mul", self.op("Mul", x, self.f32(0.5)), self.op("Add", erf, self.f32(1.0)))

    def half_bends(self, angles: str, n: int) -> str:
        """``|theta_k| / 2 + |theta_{k+1}| / 2`` of guides 1..N-1, shape (N-1, 1) [rad]: paper Eq. (3) less ``alpha_0``.

        ``|theta| = sqrt(theta_x^2 + theta_y^2)``, summed in that order, as numpy's norm does.
        """
        x, y = self.slice(angles, [0], [1], [1]), self.slice(angles, [1], [2], [1])
        mag = self.op("Sqrt", self.op("Add", self.op("Mul", x, x), self.op("Mul", y, y)))  # (N, 1)
        half = self.f64(0.5)
        return self.op(
            "Add", self.op("Mul", half, self.rows(mag, 0, n - 1)), self.op("Mul", half, self.rows(mag, 1, n))
        )

    # ---- the model ---------------------------------------------------------------------
    def model(self, name: str, doc: str, producer_version: str) -> onnx.ModelProto:
        graph = helper.make_graph(self.nodes, name, self.inputs, self.outputs, self.initializers, doc_string=doc)
        model = helper.make_model(
            graph,
            opset_imports=[helper.make_opsetid("", OPSET)],
            producer_name="tendon-id",
            producer_version=producer_version,
            doc_string=doc,
        )
        model.ir_version = 8  # what onnxruntime 1.14 and later read; onnx's default follows its own release
        onnx.checker.check_model(model, full_check=True)
        return model
