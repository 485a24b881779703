"""The compiled laws on the device: numba's Python translated into Warp functions, so that each law is written once.

The controllers' laws, the task's regions and book of success, the retirement bound and the noise are plain
Python in the package (numba's ``register_jitable`` or ``njit`` functions, also run by NumPy); Warp compiles
a restricted Python too (``@wp.func``). :func:`device_function` turns one of the package's functions, with
everything it calls, into a Warp function by rewriting its syntax tree, so that the engine on MuJoCo Warp
(:mod:`paa_mj.sim.warp.engine`) evaluates the very source the CPU engine compiles:

- ``np.cos``, ``np.arctan2``, ``math.sqrt``, ``math.isfinite`` ... become Warp's built-ins; ``math.pi`` and float
  constants of the modules become numbers of the device's float type (``real``, float32 by default);
- float literals are made of that type and an integer literal beside a value takes the value's type
  (``2 * d1`` is ``type(d1)(2) * d1``): Warp, unlike numba, mixes no types in arithmetic;
- ``a if c else b`` is Warp's, a literal branch of the other branch's type (``0.0 if k < d else x[k]`` is
  ``type(x[k])(0.0) if k < d else x[k]``);
- a variable given a literal or a module's constant is declared as a variable (Warp reads ``s = 0.0`` as a
  constant a loop may not change), ``a % b`` is Python's floored remainder (Warp's ``%`` is C's), ``x.size`` of a
  vector is ``x.shape[0]``, ``a, b = f()`` into array elements goes through a temporary, ``x[:] = v`` is a loop
  and ``np.empty(k)`` a local vector of the state's size (``2 n``, the one length the laws allocate);
- 2-d scratch is a view of a flat float64 array, :func:`paa_mj.model.chain.matrix_view`, which becomes Warp's
  array made in the kernel from the flat array's address (``np.ascontiguousarray`` of a view is the view);
- types are never converted implicitly: a function meant for arrays of several float types converts where they
  meet, as the noise's ``np.float64(...)`` does (a no-op where numba's arrays are float64 already);
- every function called is translated the same way; arguments named in ``bind`` are fixed to given Warp
  functions (the controller pair and switch of :func:`paa_mj.sim.compiled.step.call_controller`).

A construct outside this subset raises :class:`TranslationError` naming the function and the line. The
translated source is kept in :mod:`linecache` (Warp reads a function's source) and Warp caches what it compiles
on disk under the package's cache folder (:func:`paa_mj.sim.warp.device.load_warp`).
"""
from __future__ import annotations

import ast
import builtins
import inspect
import linecache
import math
import textwrap
import typing

import numpy as np

from ...errors import PaaError
from ...model import chain


class TranslationError(PaaError):
    """A function uses Python that the translation to Warp does not cover."""


#: NumPy and math functions and the Warp built-ins they become (names under ``wp``; None: a Python built-in Warp
#: knows by the same name).
_FUNCTIONS = {
    np.cos: "cos", np.sin: "sin", np.tan: "tan", np.arctan2: "atan2", np.arctan: "atan", np.sqrt: "sqrt",
    np.exp: "exp", np.log: "log", np.abs: None, np.absolute: None, np.maximum: "max", np.minimum: "min",
    np.floor: "floor", np.isfinite: "isfinite", np.tanh: "tanh", np.fabs: None,
    math.cos: "cos", math.sin: "sin", math.tan: "tan", math.atan2: "atan2", math.atan: "atan", math.sqrt: "sqrt",
    math.exp: "exp", math.log: "log", math.fabs: None, math.floor: "floor", math.isfinite: "isfinite",
    math.tanh: "tanh", np.uint64: "uint64", np.int64: "int64", np.float64: "float64", np.float32: "float32",
}
_PYTHON_NAMES = {np.abs: "abs", np.absolute: "abs", np.fabs: "abs", math.fabs: "abs"}
#: Python built-ins Warp compiles as they are.
_BUILTINS = {"abs", "min", "max", "range", "int", "float", "bool", "len"}


def _python_function(obj):
    """The Python function behind a numba dispatcher or a plain (``register_jitable``) function, else None."""
    py = getattr(obj, "py_func", obj)
    return py if inspect.isfunction(py) else None


class _Namespace:
    """The Warp functions translated for one float type and one state size, by the Python function they come from."""

    def __init__(self, wp, real, state_size):
        self.wp, self.real, self.state_size = wp, real, state_size
        tag = f"{'f64' if real is wp.float64 else 'f32'}_s{state_size}"
        self.module = f"paa_mj_device_{tag}"
        self.globals = {"__name__": self.module, "wp": wp, "Any": typing.Any, "REAL": real,
                        "STATE_SIZE": state_size}
        self.done = {}  # (python function, bound names) -> name in globals
        self.bindings = 0
        self.globals["_pymod"] = self._define("_pymod", textwrap.dedent("""\
            def _pymod(a: Any, b: Any):
                m = wp.mod(a, b)
                if m != type(m)(0) and ((m < type(m)(0)) != (b < type(b)(0))):
                    m = m + b
                return m
            """))
        self.globals["_matrix_view"] = self._define("_matrix_view", textwrap.dedent("""\
            def _matrix_view(work: Any, start: int, rows: int, cols: int):
                return wp.array(ptr=work.ptr + wp.uint64(start * 8), shape=(rows, cols), dtype=wp.float64)
            """))

    def _define(self, name, source):
        filename = f"<paa_mj device {self.module}.{name}>"
        linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
        code = compile(source, filename, "exec")
        exec(code, self.globals)  # noqa: S102 - our own functions' source, rewritten
        return self.wp.func(self.globals[name])

    def function(self, fn, bind=None):
        """The Warp function of ``fn`` (a Python function or numba dispatcher), its arguments ``bind`` fixed."""
        py = _python_function(fn)
        if py is None:
            raise TranslationError(f"{fn!r} is not a Python function: nothing to translate to Warp")
        bind = dict(bind or {})
        key = (py, tuple(sorted((k, id(v)) for k, v in bind.items())))
        if key in self.done:
            return self.globals[self.done[key]]
        if bind:  # a new name for each binding: a count that never goes back (an entry is dropped on failure)
            self.bindings += 1
        suffix = f"__bound{self.bindings}" if bind else ""
        name = f"{py.__module__.replace('.', '_')}__{py.__name__}{suffix}"
        self.done[key] = name  # before the body: a recursive call would find it (Warp refuses recursion anyway)
        bound = {}
        for arg, device in bind.items():
            bound[arg] = f"{name}_{arg}"
            self.globals[bound[arg]] = device
        try:
            source = _Rewriter(self, py, name, bound).source()
            self.globals[name] = self._define(name, source)
        except BaseException:
            del self.done[key]
            raise
        return self.globals[name]


class _Rewriter(ast.NodeTransformer):
    """Rewrites one function's syntax tree into Warp's subset (module docstring)."""

    def __init__(self, space: _Namespace, py, name, bound):
        self.space, self.py, self.name, self.bound = space, py, name, bound
        self.where = f"{py.__module__}.{py.__qualname__}"
        self.counter = 0

    def fail(self, node, what):
        line = getattr(node, "lineno", None)
        start = self.py.__code__.co_firstlineno
        at = f" (line {start + line - 1})" if line else ""
        raise TranslationError(f"cannot translate {self.where}{at} to Warp: {what}")

    def source(self) -> str:
        tree = ast.parse(textwrap.dedent(inspect.getsource(self.py)))
        fdef = tree.body[0]
        if not isinstance(fdef, ast.FunctionDef):
            self.fail(fdef, "not a function definition")
        args = fdef.args
        if args.vararg or args.kwarg or args.kwonlyargs or args.defaults or args.posonlyargs:
            self.fail(fdef, "only plain positional arguments are translated")
        self.locals = {a.arg for a in args.args}
        for node in ast.walk(fdef):
            if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                self.locals.add(node.id)
        fdef.decorator_list = []
        fdef.returns = None
        fdef.name = self.name
        fdef.args.args = [ast.arg(arg=a.arg, annotation=ast.Name("Any", ast.Load()))
                          for a in args.args if a.arg not in self.bound]
        body = fdef.body
        if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                and isinstance(body[0].value.value, str):
            body = body[1:] or [ast.Pass()]
        fdef.body = self.statements(body)
        return ast.unparse(ast.fix_missing_locations(tree)) + "\n"

    # --- statements ------------------------------------------------------------------------------------------

    def statements(self, body):
        out = []
        for stmt in body:
            for piece in self.hoisted(stmt):
                result = self.visit(piece)
                out.extend(result if isinstance(result, list) else [result])
        return out

    def hoisted(self, stmt):
        """``f(...)[k]`` (Warp indexes no call's result) as ``_t = f(...)`` before the statement and ``_t[k]`` in it;
        the package's laws are pure, so that evaluating the call first changes nothing but where."""
        before = []
        owner = self

        class Hoist(ast.NodeTransformer):
            def visit_Subscript(self, node):
                self.generic_visit(node)
                if isinstance(node.value, ast.Call):
                    temp = owner.fresh("r")
                    owner.locals.add(temp)
                    before.append(ast.Assign([ast.Name(temp, ast.Store())], node.value, lineno=stmt.lineno))
                    node.value = ast.Name(temp, ast.Load())
                return node

            def visit_Lambda(self, node):
                return node

        parts = {ast.If: ("test",), ast.For: ("iter",), ast.While: ()}.get(type(stmt))
        if parts is None:
            stmt = Hoist().visit(stmt)
        else:
            for field in parts:
                setattr(stmt, field, Hoist().visit(getattr(stmt, field)))
        return before + [stmt]

    def visit_If(self, node):
        node.test = self.visit(node.test)
        node.body, node.orelse = self.statements(node.body), self.statements(node.orelse)
        return node

    def visit_AugAssign(self, node):
        node.value = self.typed_literal(self.visit(node.value), self.visit(_as_load(node.target)))
        node.target = self.visit(node.target)
        return node

    def visit_Assign(self, node):
        if len(node.targets) != 1:
            self.fail(node, "chained assignment")
        target = node.targets[0]
        if isinstance(target, ast.Subscript) and isinstance(target.slice, ast.Slice) \
                and target.slice.lower is None and target.slice.upper is None and target.slice.step is None:
            # x[:] = v -> for _i in range(x.shape[0]): x[_i] = v
            index = self.fresh("i")
            array = self.visit(target.value)
            loop = ast.For(target=ast.Name(index, ast.Store()),
                           iter=ast.Call(ast.Name("range", ast.Load()), [self.length(array)], []),
                           body=[ast.Assign([ast.Subscript(array, ast.Name(index, ast.Load()), ast.Store())],
                                            self.visit(node.value))], orelse=[])
            return loop
        if isinstance(target, ast.Tuple) and any(not isinstance(e, ast.Name) for e in target.elts):
            # a, x[0] = f() -> _t = f(); a = _t[0]; x[0] = _t[1]
            temp = self.fresh("t")
            out = [ast.Assign([ast.Name(temp, ast.Store())], self.visit(node.value))]
            for k, element in enumerate(target.elts):
                value = ast.Subscript(ast.Name(temp, ast.Load()), ast.Constant(k), ast.Load())
                out.append(ast.Assign([self.visit(element)], value))
            return out
        value = node.value
        if isinstance(target, ast.Tuple) and isinstance(value, ast.Tuple):
            node.value = ast.Tuple([self.declared(v) for v in value.elts], ast.Load())
        else:
            node.value = self.declared(value)
        node.targets = [self.visit(target)]
        return node

    def declared(self, value):
        """A value assigned to a variable: a literal becomes a declared variable of its type."""
        if isinstance(value, ast.Constant) and not isinstance(value.value, str):
            if isinstance(value.value, bool):
                return ast.Call(ast.Name("bool", ast.Load()), [value], [])
            if isinstance(value.value, int):
                return ast.Call(ast.Name("int", ast.Load()), [value], [])
            return self.real(value.value)
        if isinstance(value, ast.UnaryOp) and isinstance(value.operand, ast.Constant):
            return self.declared(ast.Constant(-value.operand.value if isinstance(value.op, ast.USub)
                                              else value.operand.value)) \
                if isinstance(value.op, (ast.USub, ast.UAdd)) else self.visit(value)
        out = self.visit(value)
        if isinstance(out, ast.Constant) and not isinstance(out.value, str):
            return self.declared(out)  # a module's constant (``status = RUNNING``): a variable too
        return out

    def fresh(self, what):
        self.counter += 1
        return f"_{what}{self.counter}"

    def visit_Return(self, node):
        if node.value is not None:
            node.value = self.visit(node.value)
        return node

    def visit_For(self, node):
        if node.orelse:
            self.fail(node, "for ... else")
        node.iter = self.visit(node.iter)
        node.body = self.statements(node.body)
        return node

    def visit_While(self, node):
        if node.orelse:
            self.fail(node, "while ... else")
        node.test = self.visit(node.test)
        node.body = self.statements(node.body)
        return node

    def visit_Try(self, node):
        self.fail(node, "try")

    def visit_With(self, node):
        self.fail(node, "with")

    # --- expressions -----------------------------------------------------------------------------------------

    def real(self, value):
        return ast.Call(ast.Name("REAL", ast.Load()), [ast.Constant(float(value))], [])

    def length(self, array):
        return ast.Subscript(ast.Attribute(array, "shape", ast.Load()), ast.Constant(0), ast.Load())

    def visit_Constant(self, node):
        if isinstance(node.value, float):
            return self.real(node.value)
        return node

    def typed_literal(self, literal, partner):
        """An int literal beside ``partner`` (already rewritten), of ``partner``'s type; other nodes as they are."""
        if isinstance(literal, ast.Constant) and isinstance(literal.value, int) and not isinstance(literal.value, bool):
            if isinstance(partner, ast.Call) and isinstance(partner.func, ast.Name) and partner.func.id == "REAL":
                return self.real(literal.value)
            if self.is_literal(partner) or isinstance(partner, ast.Call) and not (
                    isinstance(partner.func, ast.Name) and partner.func.id in ("type", "int", "REAL", "abs")):
                # beside a literal, or a call's result (not evaluated twice): as it is
                return literal
            return ast.Call(ast.Call(ast.Name("type", ast.Load()), [partner], []), [literal], [])
        return literal

    @staticmethod
    def is_literal(node):
        return isinstance(node, ast.Constant) or (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                                                  and node.func.id == "REAL")

    def visit_BinOp(self, node):
        left, right = self.visit(node.left), self.visit(node.right)
        left, right = self.typed_literal(left, right), self.typed_literal(right, left)
        if isinstance(node.op, ast.Mod):
            return ast.Call(ast.Name("_pymod", ast.Load()), [left, right], [])
        if isinstance(node.op, (ast.MatMult,)):
            self.fail(node, "the @ operator")
        node.left, node.right = left, right
        return node

    def visit_Compare(self, node):
        items = [self.visit(node.left)] + [self.visit(c) for c in node.comparators]
        typed = [self.typed_literal(items[0], items[1])]
        for k in range(1, len(items)):
            typed.append(self.typed_literal(items[k], items[k - 1]))
        node.left, node.comparators = typed[0], typed[1:]
        return node

    def visit_IfExp(self, node):
        """``a if c else b``, a literal branch of the other branch's type (Warp's branches share one type)."""
        node.test = self.visit(node.test)
        body, orelse = self.visit(node.body), self.visit(node.orelse)
        node.body, node.orelse = self.branch_typed(body, orelse), self.branch_typed(orelse, body)
        return node

    def branch_typed(self, branch, other):
        if self.is_literal(branch) and not self.is_literal(other):
            value = branch.value if isinstance(branch, ast.Constant) else branch.args[0]
            return ast.Call(ast.Call(ast.Name("type", ast.Load()), [other], []), [value], [])
        return branch

    def visit_UnaryOp(self, node):
        operand = self.visit(node.operand)
        if isinstance(node.op, ast.USub) and isinstance(operand, ast.Constant) and type(operand.value) is int:
            return ast.Constant(-operand.value)
        if isinstance(node.op, ast.USub) and isinstance(operand, ast.Call) and self.is_literal(operand) \
                and isinstance(operand.args[0], ast.Constant):
            return self.real(-operand.args[0].value)
        node.operand = operand
        return node

    def visit_Name(self, node):
        if not isinstance(node.ctx, ast.Load):
            return node
        if node.id in self.bound:
            return ast.Name(self.bound[node.id], ast.Load())
        if node.id in self.locals:
            return node
        if node.id == "float":
            return ast.Name("REAL", ast.Load())
        if node.id in self.py.__globals__:
            return self.resolved(node, self.py.__globals__[node.id])
        if node.id in _BUILTINS:
            return node
        if hasattr(builtins, node.id):
            self.fail(node, f"the built-in {node.id}")
        self.fail(node, f"unknown name {node.id}")

    def visit_Attribute(self, node):
        if not isinstance(node.ctx, ast.Load):
            node.value = self.visit(node.value)
            return node
        chain = self.dotted(node)
        if chain is not None and chain[0] not in self.locals and chain[0] in self.py.__globals__:
            obj = self.py.__globals__[chain[0]]
            for part in chain[1:]:
                if not hasattr(obj, part):
                    self.fail(node, f"unknown {'.'.join(chain)}")
                obj = getattr(obj, part)
            return self.resolved(node, obj)
        if node.attr == "size":  # a local vector's length
            return self.length(self.visit(node.value))
        node.value = self.visit(node.value)
        return node

    @staticmethod
    def dotted(node):
        parts = []
        while isinstance(node, ast.Attribute):
            parts.append(node.attr)
            node = node.value
        if not isinstance(node, ast.Name):
            return None
        return [node.id] + parts[::-1]

    def resolved(self, node, obj):
        """The rewritten reference to a global ``obj``: a Warp built-in, a number or a translated function."""
        if isinstance(obj, bool):
            return ast.Constant(obj)
        if isinstance(obj, (int, np.integer)):
            return ast.Constant(int(obj))
        if isinstance(obj, (float, np.floating)):
            return self.real(float(obj))
        try:
            known = obj in _FUNCTIONS
        except TypeError:
            known = False
        if known:
            if obj in _PYTHON_NAMES:
                return ast.Name(_PYTHON_NAMES[obj], ast.Load())
            return ast.Attribute(ast.Name("wp", ast.Load()), _FUNCTIONS[obj], ast.Load())
        if obj is np.empty or obj is np.zeros:
            return ast.Name("_local_vector", ast.Load())
        if obj is np.ascontiguousarray:
            return ast.Name("_same", ast.Load())
        if obj is chain.matrix_view:
            return ast.Name("_matrix_view", ast.Load())
        if _python_function(obj) is not None:
            device = self.space.function(obj)
            name = self.space.done[(_python_function(obj), ())]
            assert self.space.globals[name] is device
            return ast.Name(name, ast.Load())
        self.fail(node, f"{ast.unparse(node)} is {type(obj).__name__}, not a number or a function")

    def visit_Call(self, node):
        func = self.visit(node.func)
        if isinstance(func, ast.Name) and func.id == "_local_vector":
            # np.empty(k) / np.zeros(k): a vector of the state's size, zeros
            return ast.Call(ast.Attribute(ast.Name("wp", ast.Load()), "vector", ast.Load()), [],
                            [ast.keyword("length", ast.Call(ast.Attribute(ast.Name("wp", ast.Load()), "static",
                                                                          ast.Load()),
                                                            [ast.Name("STATE_SIZE", ast.Load())], [])),
                             ast.keyword("dtype", ast.Name("REAL", ast.Load()))])
        if isinstance(func, ast.Name) and func.id == "_same":
            # np.ascontiguousarray(a): a view as it is (the package passes contiguous arrays; Warp's views are)
            if len(node.args) != 1 or node.keywords:
                self.fail(node, "np.ascontiguousarray of other than one array")
            return self.visit(node.args[0])
        if node.keywords:
            self.fail(node, "keyword arguments")
        if any(isinstance(a, ast.Starred) for a in node.args):
            self.fail(node, "*arguments")
        node.func = func
        node.args = [self.visit(a) for a in node.args]
        if isinstance(func, ast.Name) and func.id in ("min", "max") and len(node.args) == 2:
            a, b = node.args
            node.args = [self.typed_literal(a, b), self.typed_literal(b, a)]
        return node


def _as_load(node):
    """A copy of an assignment target read as a value."""
    copy = ast.parse(ast.unparse(node), mode="eval").body
    return copy


_SPACES = {}


def namespace(wp, real=None, state_size=6) -> _Namespace:
    """The translated functions for Warp module ``wp``, float type ``real`` (default float32) and a state of
    ``state_size`` numbers (2 n)."""
    real = wp.float32 if real is None else real
    key = (id(wp), real, int(state_size))
    if key not in _SPACES:
        _SPACES[key] = _Namespace(wp, real, int(state_size))
    return _SPACES[key]


def device_function(wp, fn, bind=None, real=None, state_size=6):
    """The Warp function of the package's function ``fn`` (module docstring); ``bind``: arguments fixed to Warp
    functions."""
    return namespace(wp, real, state_size).function(fn, bind)
