"""The syntax tree of the GLSL subset and its recursive-descent parser.

The grammar is that of the OpenGL Shading Language 4.10 (§5 operators and expressions, §6
statements, §9 the shading-language grammar), restricted to what analytic BRDFs need:
functions (``in`` parameters), ``float``/``int``/``bool``/``vec2``/``vec3``/``vec4``
variables and constants, global ``const`` and ``uniform`` declarations, expressions with
constructors, swizzles and indexing, ``if``/``else``, ``?:`` and ``for`` loops. Every other
construct of the language is refused by name with its line.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from brdfkit.interop.glsl.lexer import Token, refuse, tokenize

__all__ = [
    "TYPES",
    "Assign",
    "Binary",
    "Block",
    "Call",
    "Declaration",
    "ExpressionStatement",
    "For",
    "Function",
    "If",
    "Index",
    "Name",
    "Number",
    "Parameter",
    "Program",
    "Return",
    "Step",
    "Swizzle",
    "Ternary",
    "Unary",
    "parse",
]

TYPES = ("void", "bool", "int", "float", "vec2", "vec3", "vec4")
"""The types of the subset."""

_REFUSED_WORDS = {
    "while": "'while' loop",
    "do": "'do' loop",
    "break": "'break'",
    "continue": "'continue'",
    "discard": "'discard'",
    "switch": "'switch'",
    "struct": "'struct'",
    "out": "'out' parameter",
    "inout": "'inout' parameter",
    "precision": "'precision' statement",
    "layout": "'layout' qualifier",
}
_REFUSED_TYPES = re.compile(
    r"d?mat[234](x[234])?|[ibud]vec[234]|uint|double|atomic_uint"
    r"|[iu]?(sampler|image)(1D|2D|3D|Cube|2DRect|Buffer)\w*"
)
_ASSIGNMENTS = ("=", "+=", "-=", "*=", "/=")
_BINARY_LEVELS = (("||",), ("^^",), ("&&",), ("==", "!="), ("<", ">", "<=", ">="), ("+", "-"))
_MULTIPLICATIVE = ("*", "/", "%")


# --------------------------------------------------------------------------- expressions
@dataclass(frozen=True)
class Number:
    """A literal: ``value`` a Python ``int`` (``2``) or ``float`` (``2.0``, ``2e-3``)."""

    value: int | float
    line: int


@dataclass(frozen=True)
class Name:
    """A variable, constant or uniform read by name."""

    name: str
    line: int


@dataclass(frozen=True)
class Call:
    """A call of a function, a built-in or a constructor (``vec3(…)``)."""

    name: str
    arguments: tuple[Any, ...]
    line: int


@dataclass(frozen=True)
class Unary:
    """``-x``, ``+x`` or ``!x``."""

    operator: str
    operand: Any
    line: int


@dataclass(frozen=True)
class Binary:
    """``a OP b`` for the arithmetic, relational, equality and logical operators."""

    operator: str
    left: Any
    right: Any
    line: int


@dataclass(frozen=True)
class Ternary:
    """``condition ? if_true : if_false``."""

    condition: Any
    if_true: Any
    if_false: Any
    line: int


@dataclass(frozen=True)
class Swizzle:
    """``value.xyz``: ``fields`` the component indices (``(0, 1, 2)``)."""

    value: Any
    fields: tuple[int, ...]
    line: int


@dataclass(frozen=True)
class Index:
    """``value[index]`` on a vector."""

    value: Any
    index: Any
    line: int


# --------------------------------------------------------------------------- statements
@dataclass(frozen=True)
class Declaration:
    """``[const|uniform] TYPE name [= value], …;``: ``variables`` the ``(name, value or
    None)`` pairs."""

    type: str
    variables: tuple[tuple[str, Any], ...]
    qualifier: str
    line: int


@dataclass(frozen=True)
class Assign:
    """``target OP value`` for ``=``, ``+=``, ``-=``, ``*=``, ``/=``; ``target`` a
    :class:`Name`, or a :class:`Swizzle` or :class:`Index` of one."""

    operator: str
    target: Any
    value: Any
    line: int


@dataclass(frozen=True)
class Step:
    """``++x``, ``x++``, ``--x`` or ``x--`` as a statement or a ``for`` loop's step."""

    target: Any
    delta: int
    line: int


@dataclass(frozen=True)
class ExpressionStatement:
    """An expression evaluated for nothing (a call): ``f(x);``."""

    expression: Any
    line: int


@dataclass(frozen=True)
class Block:
    """``{ statements }``: a scope."""

    statements: tuple[Any, ...]
    line: int


@dataclass(frozen=True)
class If:
    """``if (condition) then [else otherwise]``."""

    condition: Any
    then: Any
    otherwise: Any
    line: int


@dataclass(frozen=True)
class For:
    """``for (init; condition; step) body`` (a loop whose condition is the same for every
    direction)."""

    init: Any
    condition: Any
    step: Any
    body: Any
    line: int


@dataclass(frozen=True)
class Return:
    """``return [value];``."""

    value: Any
    line: int


# --------------------------------------------------------------------------- the program
@dataclass(frozen=True)
class Parameter:
    """A function parameter: its type and name (``in`` is the only direction)."""

    type: str
    name: str


@dataclass(frozen=True)
class Function:
    """A function definition."""

    type: str
    name: str
    parameters: tuple[Parameter, ...]
    body: Block
    line: int


@dataclass(frozen=True)
class Program:
    """A parsed translation unit: its functions by name and its global declarations in order,
    with the ``path`` its errors name."""

    functions: dict[str, Function]
    globals: tuple[Declaration, ...]
    path: str


# --------------------------------------------------------------------------- the parser
class _Parser:
    def __init__(self, tokens: list[Token], path: str) -> None:
        self.tokens = tokens
        self.path = path
        self.position = 0

    # -- tokens -----------------------------------------------------------------------------
    @property
    def token(self) -> Token:
        return self.tokens[self.position]

    def peek(self, ahead: int = 1) -> Token:
        return self.tokens[min(self.position + ahead, len(self.tokens) - 1)]

    def advance(self) -> Token:
        token = self.token
        self.position = min(self.position + 1, len(self.tokens) - 1)
        return token

    def accept(self, text: str) -> bool:
        if self.token.kind in ("op", "name") and self.token.text == text:
            self.advance()
            return True
        return False

    def expect(self, text: str, where: str) -> Token:
        if self.token.text != text or self.token.kind == "end":
            raise self.error(f"expected '{text}' {where}, found {self._shown(self.token)}")
        return self.advance()

    def error(self, construct: str, token: Token | None = None) -> Exception:
        return refuse(self.path, (token or self.token).line, construct)

    @staticmethod
    def _shown(token: Token) -> str:
        return "the end of the shader" if token.kind == "end" else f"'{token.text}'"

    def name(self, what: str) -> str:
        if self.token.kind != "name":
            raise self.error(f"expected {what}, found {self._shown(self.token)}")
        self.check_word(self.token)
        return self.advance().text

    def check_word(self, token: Token) -> None:
        if token.kind == "name" and token.text in _REFUSED_WORDS:
            raise self.error(f"unsupported construct {_REFUSED_WORDS[token.text]}", token)
        if token.kind == "name" and _REFUSED_TYPES.fullmatch(token.text):
            raise self.error(f"unsupported type '{token.text}'", token)

    def is_type(self) -> bool:
        self.check_word(self.token)
        return self.token.kind == "name" and self.token.text in TYPES

    def type_name(self) -> str:
        if not self.is_type():
            raise self.error(f"expected a type, found {self._shown(self.token)}")
        return self.advance().text

    # -- top level --------------------------------------------------------------------------
    def program(self) -> Program:
        functions: dict[str, Function] = {}
        declarations: list[Declaration] = []
        while self.token.kind != "end":
            if self.accept(";"):
                continue
            qualifier = self.qualifier()
            line = self.token.line
            type_ = self.type_name()
            name_token = self.token
            name = self.name("a name")
            if self.token.text == "(" and not qualifier:
                function = self.function(type_, name, line)
                if function is None:  # a prototype: the definition follows
                    continue
                if name in functions:
                    raise self.error(f"function '{name}' defined twice (overloading)", name_token)
                functions[name] = function
            else:
                declarations.append(self.declaration_rest(type_, name, qualifier, line))
        return Program(functions, tuple(declarations), self.path)

    def qualifier(self) -> str:
        for word in ("const", "uniform"):
            if self.accept(word):
                return word
        if self.token.text in ("in", "varying", "attribute", "buffer", "shared"):
            raise self.error(f"unsupported global qualifier '{self.token.text}'")
        return ""

    def function(self, type_: str, name: str, line: int) -> Function | None:
        self.expect("(", f"after the function name '{name}'")
        parameters: list[Parameter] = []
        if self.token.text == "void" and self.peek().text == ")":
            self.advance()
        while self.token.text != ")":
            if parameters:
                self.expect(",", "between parameters")
            self.accept("const")
            self.accept("in")
            p_type = self.type_name()
            if p_type == "void":
                raise self.error("a parameter of type 'void'")
            parameters.append(Parameter(p_type, self.name("a parameter name")))
            if self.token.text == "[":
                raise self.error("unsupported construct array parameter")
        self.expect(")", f"after the parameters of '{name}'")
        if self.accept(";"):
            return None
        if self.token.text != "{":
            raise self.error(f"expected '{{' to begin the body of '{name}'")
        return Function(type_, name, tuple(parameters), self.block(), line)

    def declaration_rest(self, type_: str, first: str, qualifier: str, line: int) -> Declaration:
        if type_ == "void":
            raise self.error(f"a variable '{first}' of type 'void'")
        variables = []
        name = first
        while True:
            if self.token.text == "[":
                raise self.error(f"unsupported construct array '{name}[…]'")
            value = self.assignment_expression() if self.accept("=") else None
            if qualifier == "const" and value is None:
                raise self.error(f"constant '{name}' without a value")
            variables.append((name, value))
            if not self.accept(","):
                break
            name = self.name("a variable name")
        self.expect(";", f"after the declaration of '{name}'")
        return Declaration(type_, tuple(variables), qualifier, line)

    # -- statements -------------------------------------------------------------------------
    def block(self) -> Block:
        line = self.expect("{", "to begin a block").line
        statements = []
        while not self.accept("}"):
            if self.token.kind == "end":
                raise self.error("expected '}' to end the block opened on line " + str(line))
            statements.append(self.statement())
        return Block(tuple(statements), line)

    def statement(self) -> Any:
        token = self.token
        self.check_word(token)
        if token.text == "{" and token.kind == "op":
            return self.block()
        if token.kind == "name" and token.text == "if":
            return self.if_statement()
        if token.kind == "name" and token.text == "for":
            return self.for_statement()
        if token.kind == "name" and token.text == "return":
            self.advance()
            value = None if self.token.text == ";" else self.expression()
            self.expect(";", "after 'return'")
            return Return(value, token.line)
        if token.kind == "op" and token.text == ";":
            self.advance()
            return Block((), token.line)
        statement = self.simple_statement()
        self.expect(";", "at the end of the statement")
        return statement

    def simple_statement(self) -> Any:
        """A declaration, assignment, step or call, without its ``;`` (also a ``for``
        loop's init and step)."""
        line = self.token.line
        if self.token.kind == "name" and self.token.text == "const":
            self.advance()
            type_ = self.type_name()
            return self.local_declaration(type_, "const", line)
        if self.is_type():
            type_ = self.advance().text
            return self.local_declaration(type_, "", line)
        if self.token.text in ("++", "--"):
            delta = 1 if self.advance().text == "++" else -1
            return Step(self.unary(), delta, line)
        target = self.ternary()
        if self.token.text in _ASSIGNMENTS:
            operator = self.advance().text
            return Assign(operator, target, self.assignment_expression(), line)
        if self.token.text in ("++", "--"):
            return Step(target, 1 if self.advance().text == "++" else -1, line)
        if not isinstance(target, Call):
            raise self.error("an expression statement that does nothing")
        return ExpressionStatement(target, line)

    def local_declaration(self, type_: str, qualifier: str, line: int) -> Declaration:
        declaration = self.declaration_rest(type_, self.name("a variable name"), qualifier, line)
        self.position -= 1  # give the ';' back to the statement
        return declaration

    def if_statement(self) -> If:
        line = self.advance().line
        self.expect("(", "after 'if'")
        condition = self.expression()
        self.expect(")", "after the condition of 'if'")
        then = self.statement()
        otherwise = self.statement() if self.accept("else") else None
        return If(condition, then, otherwise, line)

    def for_statement(self) -> For:
        line = self.advance().line
        self.expect("(", "after 'for'")
        init = None if self.token.text == ";" else self.simple_statement()
        self.expect(";", "after the initialisation of 'for'")
        condition = None if self.token.text == ";" else self.expression()
        self.expect(";", "after the condition of 'for'")
        step = None if self.token.text == ")" else self.simple_statement()
        self.expect(")", "after the step of 'for'")
        return For(init, condition, step, self.statement(), line)

    # -- expressions ------------------------------------------------------------------------
    def expression(self) -> Any:
        value = self.assignment_expression()
        if self.token.text == ",":
            raise self.error("unsupported construct comma operator")
        return value

    def assignment_expression(self) -> Any:
        value = self.ternary()
        if self.token.text in _ASSIGNMENTS:
            raise self.error("unsupported construct assignment inside an expression")
        return value

    def ternary(self) -> Any:
        condition = self.binary(0)
        if self.token.text != "?":
            return condition
        line = self.advance().line
        if_true = self.assignment_expression()
        self.expect(":", "in a '?:' expression")
        return Ternary(condition, if_true, self.assignment_expression(), line)

    def binary(self, level: int) -> Any:
        if level == len(_BINARY_LEVELS):
            return self.multiplicative()
        left = self.binary(level + 1)
        while self.token.kind == "op" and self.token.text in _BINARY_LEVELS[level]:
            token = self.advance()
            left = Binary(token.text, left, self.binary(level + 1), token.line)
        if self.token.kind == "op" and self.token.text in ("&", "|", "^", "<<", ">>", "~"):
            raise self.error(f"unsupported construct bitwise operator '{self.token.text}'")
        return left

    def multiplicative(self) -> Any:
        left = self.unary()
        while self.token.kind == "op" and self.token.text in _MULTIPLICATIVE:
            token = self.advance()
            left = Binary(token.text, left, self.unary(), token.line)
        return left

    def unary(self) -> Any:
        token = self.token
        if token.kind == "op" and token.text in ("-", "+", "!"):
            self.advance()
            return Unary(token.text, self.unary(), token.line)
        if token.kind == "op" and token.text in ("++", "--"):
            raise self.error(f"unsupported construct '{token.text}' inside an expression")
        if token.kind == "op" and token.text == "~":
            raise self.error("unsupported construct bitwise operator '~'")
        return self.postfix(self.primary())

    def postfix(self, value: Any) -> Any:
        while True:
            token = self.token
            if token.text == "." and token.kind == "op":
                self.advance()
                value = Swizzle(value, self.swizzle_fields(self.name("a swizzle")), token.line)
            elif token.text == "[" and token.kind == "op":
                self.advance()
                index = self.expression()
                self.expect("]", "after an index")
                value = Index(value, index, token.line)
            else:
                return value

    def swizzle_fields(self, text: str) -> tuple[int, ...]:
        for letters in ("xyzw", "rgba", "stpq"):
            if all(c in letters for c in text) and 1 <= len(text) <= 4:
                return tuple(letters.index(c) for c in text)
        raise self.error(f"swizzle '.{text}' (components are xyzw, rgba or stpq, at most 4)")

    def primary(self) -> Any:
        token = self.token
        if token.kind == "number":
            self.advance()
            return Number(_number(token.text), token.line)
        if token.kind == "name" and token.text in ("true", "false"):
            self.advance()
            return Call("bool", (Number(int(token.text == "true"), token.line),), token.line)
        if token.kind == "op" and token.text == "(":
            self.advance()
            value = self.expression()
            self.expect(")", "to close '('")
            return value
        if token.kind == "name":
            self.check_word(token)
            self.advance()
            if self.token.text == "(" and self.token.kind == "op":
                return Call(token.text, self.arguments(token.text), token.line)
            return Name(token.text, token.line)
        raise self.error(f"expected an expression, found {self._shown(token)}")

    def arguments(self, name: str) -> tuple[Any, ...]:
        self.advance()
        arguments: list[Any] = []
        if self.token.text == "void" and self.peek().text == ")":
            self.advance()
        while self.token.text != ")":
            if arguments:
                self.expect(",", f"between the arguments of '{name}'")
            arguments.append(self.assignment_expression())
        self.advance()
        return tuple(arguments)


def _number(text: str) -> int | float:
    body = text.rstrip("fF")
    if body == text and body.isdigit():
        return int(body)
    return float(body)


def parse(source: str | Iterable[tuple[int, str]], path: str = "<glsl>") -> Program:
    """The :class:`Program` of GLSL ``source`` (a string, or ``(line number, text)`` pairs
    whose numbers the errors name).

    Raises
    ------
    brdfkit.errors.FormatError
        Naming ``path``, the line and the construct, for anything outside the subset or a
        syntax error.

    Examples
    --------
    >>> program = parse("float sqr(float x) { return x*x; }")
    >>> sorted(program.functions), program.functions["sqr"].parameters
    (['sqr'], (Parameter(type='float', name='x'),))
    >>> parse("void f() { while (true) {} }", "loop.glsl")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.FormatError: loop.glsl (line 1): GLSL: unsupported construct 'while' loop
    """
    return _Parser(tokenize(source, path), path).program()
