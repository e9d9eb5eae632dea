"""Evaluation of a parsed GLSL program over arrays, one lane per direction.

The program is never turned into Python source: its syntax tree is walked once per call, and
every operation is an array operation of the namespace of the inputs (NumPy, PyTorch, JAX), so
that a shader evaluates a whole batch of directions at once and stays differentiable.

Control flow that differs between lanes runs as a GPU runs it (SIMT execution with an active
mask): both sides of an ``if`` run, each under the mask of the lanes that take it, and an
assignment changes only the active lanes; a ``return`` records its value in the active lanes
and retires them. A condition that is the same for every lane (a ``bool`` parameter, a loop
counter) takes one branch only, as a CPU would. ``for`` loops need such a uniform condition.

References
----------
.. [1] J. Kessenich, D. Baldwin, R. Rost, *The OpenGL Shading Language*, version 4.10, 2010.
.. [2] E. Lindholm, J. Nickolls, S. Oberman, J. Montrym, "NVIDIA Tesla: a unified graphics and
       computing architecture", IEEE Micro 28(2), 2008 (SIMT execution of divergent branches).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from brdfkit.interop.glsl.builtins import BUILTINS, CONSTRUCTORS, call_builtin, construct
from brdfkit.interop.glsl.lexer import refuse
from brdfkit.interop.glsl.syntax import (
    Assign,
    Binary,
    Block,
    Call,
    Declaration,
    ExpressionStatement,
    For,
    Function,
    If,
    Index,
    Name,
    Number,
    Program,
    Return,
    Step,
    Swizzle,
    Ternary,
    Unary,
)
from brdfkit.interop.glsl.values import SIZES, Arithmetic, Value, concrete

__all__ = ["MAX_CALL_DEPTH", "MAX_LOOP_ITERATIONS", "check_calls", "run"]

MAX_LOOP_ITERATIONS = 65536
"""The most iterations a ``for`` loop may run before it is refused."""

MAX_CALL_DEPTH = 64
"""The deepest chain of calls (GLSL forbids recursion; a deeper chain is refused)."""


class _Frame:
    """The state of one function call: scopes of variables, the active lanes, the value
    returned so far."""

    def __init__(self, return_type: str) -> None:
        self.scopes: list[dict[str, Value]] = [{}]
        self.active: Any = True
        self.returned: Value | None = None
        self.return_type = return_type

    def find(self, name: str) -> dict[str, Value] | None:
        for scope in reversed(self.scopes):
            if name in scope:
                return scope
        return None


class _Evaluation:
    def __init__(self, program: Program, globals_: dict[str, Value], like: Any) -> None:
        self.program = program
        self.globals = globals_
        self.ar = Arithmetic(like, self.error)
        self.depth = 0

    def error(self, line: int, construct: str) -> Exception:
        return refuse(self.program.path, line, construct)

    # -- calls ------------------------------------------------------------------------------
    def call(self, function: Function, args: list[Value], line: int) -> Value:
        if len(args) != len(function.parameters):
            raise self.error(
                line,
                f"'{function.name}' takes {len(function.parameters)} arguments, got {len(args)}",
            )
        if self.depth >= MAX_CALL_DEPTH:
            raise self.error(line, f"calls nested over {MAX_CALL_DEPTH} deep (recursion)")
        frame = _Frame(function.type)
        for p, a in zip(function.parameters, args, strict=True):
            frame.scopes[0][p.name] = self.ar.convert(a, p.type, line, f"argument '{p.name}'")
        self.depth += 1
        try:
            self.block(function.body.statements, frame)
        finally:
            self.depth -= 1
        if frame.returned is None:
            if function.type != "void":
                raise self.error(function.line, f"'{function.name}' returns no value")
            return Value("void", ())
        return frame.returned

    # -- statements -------------------------------------------------------------------------
    def block(self, statements: Sequence[Any], frame: _Frame) -> None:
        frame.scopes.append({})
        try:
            for statement in statements:
                if frame.active is False:
                    break
                self.statement(statement, frame)
        finally:
            frame.scopes.pop()

    def statement(self, node: Any, frame: _Frame) -> None:
        if isinstance(node, Block):
            self.block(node.statements, frame)
        elif isinstance(node, Declaration):
            self.declare(node, frame.scopes[-1], frame)
        elif isinstance(node, Assign):
            self.assign(node, frame)
        elif isinstance(node, Step):
            one = Number(1, node.line)
            self.assign(
                Assign("+=" if node.delta > 0 else "-=", node.target, one, node.line), frame
            )
        elif isinstance(node, ExpressionStatement):
            self.expression(node.expression, frame)
        elif isinstance(node, If):
            self.if_statement(node, frame)
        elif isinstance(node, For):
            self.for_statement(node, frame)
        elif isinstance(node, Return):
            self.return_statement(node, frame)
        else:  # the parser makes no other node
            raise self.error(getattr(node, "line", 0), f"statement {type(node).__name__}")

    def declare(self, node: Declaration, scope: dict[str, Value], frame: _Frame | None) -> None:
        for name, init in node.variables:
            if init is None:
                value = self.zero(node.type)
            else:
                value = self.ar.convert(
                    self.expression(init, frame), node.type, node.line, f"the value of '{name}'"
                )
            scope[name] = value

    def zero(self, type_: str) -> Value:
        """The value of a declared variable before its first assignment (undefined in GLSL)."""
        if type_ == "bool":
            return Value("bool", (False,))
        if type_ == "int":
            return Value("int", (0,))
        return Value(type_, tuple(self.ar.number(0) for _ in range(SIZES[type_])))

    def assign(self, node: Assign, frame: _Frame) -> None:
        target, name = node.target, None
        base = target.value if isinstance(target, Swizzle | Index) else target
        if not isinstance(base, Name):
            raise self.error(node.line, "assignment to something that is not a variable")
        name = base.name
        scope = frame.find(name)
        if scope is None:
            where = "a global or uniform" if name in self.globals else "an undeclared variable"
            raise self.error(node.line, f"assignment to {where} '{name}'")
        old = scope[name]
        value = self.expression(node.value, frame)
        if node.operator != "=":
            current = self.expression(target, frame)
            value = self.ar.arithmetic(node.operator[0], current, value, node.line)
        new = self.store(old, target, value, frame, node.line)
        scope[name] = self.ar.select(frame.active, new, old, node.line)

    def store(self, old: Value, target: Any, value: Value, frame: _Frame, line: int) -> Value:
        """``old`` with ``value`` written where ``target`` (the variable, a swizzle or an
        index of it) points."""
        if isinstance(target, Name):
            return self.ar.convert(value, old.type, line, f"the value of '{target.name}'")
        if isinstance(target, Swizzle):
            fields = target.fields
            if len(set(fields)) != len(fields):
                raise self.error(line, "a swizzle that repeats a component on the left of '='")
        else:
            fields = (self.constant_index(target, old, frame),)
        if max(fields) >= old.size or old.type not in ("vec2", "vec3", "vec4"):
            raise self.error(line, f"components {fields} of {old.type}")
        parts = list(old.parts)
        expected = "float" if len(fields) == 1 else f"vec{len(fields)}"
        written = self.ar.convert(value, expected, line, "the value written")
        for field, part in zip(fields, written.parts, strict=True):
            parts[field] = part
        return Value(old.type, tuple(parts))

    def constant_index(self, node: Index, vector: Value, frame: _Frame | None) -> int:
        index = self.expression(node.index, frame)
        part = index.parts[0]
        if index.type != "int" or not isinstance(part, int):
            raise self.error(node.line, "an index that is not a constant int")
        if not 0 <= part < vector.size:
            raise self.error(node.line, f"index {part} of {vector.type}")
        return part

    def condition(self, node: Any, frame: _Frame | None, what: str) -> Any:
        value = self.expression(node, frame)
        if value.type != "bool":
            raise self.error(node.line, f"{what} of type {value.type} (a bool is needed)")
        return concrete(value.parts[0])

    def if_statement(self, node: If, frame: _Frame) -> None:
        condition = self.condition(node.condition, frame, "the condition of 'if'")
        if isinstance(condition, bool):
            chosen = node.then if condition else node.otherwise
            if chosen is not None:
                self.statement(chosen, frame)
            return
        ar, entry = self.ar, frame.active
        frame.active = ar.both(entry, condition)
        self.statement(node.then, frame)
        after_then = frame.active
        frame.active = ar.both(entry, ar.negate(condition))
        if node.otherwise is not None:
            self.statement(node.otherwise, frame)
        frame.active = ar.either(after_then, frame.active)

    def for_statement(self, node: For, frame: _Frame) -> None:
        frame.scopes.append({})
        try:
            if node.init is not None:
                self.statement(node.init, frame)
            for _ in range(MAX_LOOP_ITERATIONS):
                if node.condition is not None:
                    go = self.condition(node.condition, frame, "the condition of 'for'")
                    if not isinstance(go, bool):
                        raise self.error(node.line, "a 'for' loop whose condition varies")
                    if not go:
                        return
                self.statement(node.body, frame)
                if frame.active is False:
                    return
                if node.step is not None:
                    self.statement(node.step, frame)
            raise self.error(node.line, f"a 'for' loop of over {MAX_LOOP_ITERATIONS} iterations")
        finally:
            frame.scopes.pop()

    def return_statement(self, node: Return, frame: _Frame) -> None:
        if node.value is None:
            if frame.return_type != "void":
                raise self.error(node.line, "'return' without a value")
            value = Value("void", ())
        else:
            value = self.ar.convert(
                self.expression(node.value, frame), frame.return_type, node.line, "the result"
            )
        if frame.returned is None or frame.active is True:
            frame.returned = value
        elif value.type != "void":
            frame.returned = self.ar.select(frame.active, value, frame.returned, node.line)
        frame.active = False  # every lane that ran this return has retired

    # -- expressions ------------------------------------------------------------------------
    def expression(self, node: Any, frame: _Frame | None) -> Value:
        ar = self.ar
        if isinstance(node, Number):
            if isinstance(node.value, int):
                return Value("int", (node.value,))
            return Value("float", (ar.number(node.value),))
        if isinstance(node, Name):
            return self.lookup(node, frame)
        if isinstance(node, Call):
            return self.call_expression(node, frame)
        if isinstance(node, Binary):
            return self.binary(node, frame)
        if isinstance(node, Unary):
            return self.unary(node, frame)
        if isinstance(node, Ternary):
            condition = self.condition(node.condition, frame, "the condition of '?:'")
            if isinstance(condition, bool):
                return self.expression(node.if_true if condition else node.if_false, frame)
            a, b = self.expression(node.if_true, frame), self.expression(node.if_false, frame)
            return ar.select(condition, a, b, node.line)
        if isinstance(node, Swizzle):
            value = self.expression(node.value, frame)
            if value.type in ("bool", "int") or max(node.fields) >= value.size:
                raise self.error(node.line, f"swizzle {node.fields} of {value.type}")
            parts = tuple(value.parts[i] for i in node.fields)
            return Value("float" if len(parts) == 1 else f"vec{len(parts)}", parts)
        if isinstance(node, Index):
            value = self.expression(node.value, frame)
            if not value.is_vector:
                raise self.error(node.line, f"indexing a {value.type}")
            return Value("float", (value.parts[self.constant_index(node, value, frame)],))
        raise self.error(getattr(node, "line", 0), f"expression {type(node).__name__}")

    def lookup(self, node: Name, frame: _Frame | None) -> Value:
        scope = frame.find(node.name) if frame is not None else None
        if scope is not None:
            return scope[node.name]
        if node.name in self.globals:
            return self.globals[node.name]
        raise self.error(node.line, f"undeclared name '{node.name}'")

    def call_expression(self, node: Call, frame: _Frame | None) -> Value:
        args = [self.expression(a, frame) for a in node.arguments]
        function = self.program.functions.get(node.name)
        if function is not None:
            return self.call(function, args, node.line)
        if node.name in CONSTRUCTORS:
            return construct(self.ar, node.name, args, node.line)
        if node.name in BUILTINS:
            return call_builtin(self.ar, node.name, args, node.line)
        raise self.error(node.line, f"unknown function '{node.name}'")

    def binary(self, node: Binary, frame: _Frame | None) -> Value:
        ar, operator = self.ar, node.operator
        if operator in ("&&", "||", "^^"):
            left = self.condition(node.left, frame, f"the left side of '{operator}'")
            if (operator == "&&" and left is False) or (operator == "||" and left is True):
                return Value("bool", (left,))
            right = self.condition(node.right, frame, f"the right side of '{operator}'")
            combine = {"&&": ar.both, "||": ar.either, "^^": ar.differ}[operator]
            return Value("bool", (concrete(combine(left, right)),))
        left, right = self.expression(node.left, frame), self.expression(node.right, frame)
        if operator in ("+", "-", "*", "/", "%"):
            return ar.arithmetic(operator, left, right, node.line)
        return ar.compare(operator, left, right, node.line)

    def unary(self, node: Unary, frame: _Frame | None) -> Value:
        value = self.expression(node.operand, frame)
        if node.operator == "!":
            if value.type != "bool":
                raise self.error(node.line, f"'!' on {value.type}")
            return Value("bool", (self.ar.negate(value.parts[0]),))
        if value.type == "bool":
            raise self.error(node.line, f"'{node.operator}' on bool")
        if node.operator == "+":
            return value
        return Value(value.type, tuple(-p for p in value.parts))


def check_calls(program: Program) -> None:
    """Refuse, before any evaluation, a call of a function that is neither defined, built in
    nor a constructor (naming the file, line and name)."""
    known = set(program.functions) | set(CONSTRUCTORS) | set(BUILTINS)

    def visit(node: Any) -> None:
        if isinstance(node, Call) and node.name not in known:
            raise refuse(program.path, node.line, f"unknown function '{node.name}'")
        if isinstance(node, tuple):
            for item in node:
                visit(item)
        elif hasattr(node, "__dataclass_fields__"):
            for key in node.__dataclass_fields__:
                visit(getattr(node, key))

    visit(tuple(program.functions.values()))
    visit(program.globals)


def run(
    program: Program,
    name: str,
    arguments: Sequence[Value],
    uniforms: Mapping[str, Value],
    like: Any,
) -> Value:
    """Call function ``name`` of ``program`` with ``arguments``, its ``uniform`` parameters
    (and any extra globals) given by ``uniforms``; arithmetic in the namespace and dtype of
    the array ``like``.

    Global declarations are evaluated first, in order (a ``uniform`` one takes its value from
    ``uniforms``). Floating-point exceptions follow IEEE arithmetic, as on a GPU: a division by
    zero gives ∞ or NaN, never an error.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the program's path, the line and the construct, for a name, type or call the
        subset cannot evaluate.
    """
    evaluation = _Evaluation(program, dict(uniforms), like)
    with np.errstate(all="ignore"):
        for declaration in program.globals:
            if declaration.qualifier == "uniform":
                for variable, _ in declaration.variables:
                    if variable not in uniforms:
                        raise evaluation.error(
                            declaration.line, f"no value for uniform '{variable}'"
                        )
                continue
            evaluation.declare(declaration, evaluation.globals, None)
        function = program.functions.get(name)
        if function is None:
            raise refuse(program.path, 1, f"no function '{name}'")
        return evaluation.call(function, list(arguments), function.line)
