"""Tokens of the GLSL subset, with object-like ``#define`` constants expanded.

The tokenizer follows the lexical grammar of the OpenGL Shading Language (Kessenich, Baldwin,
Rost, *The OpenGL Shading Language* 4.10, §3): ``//`` and ``/* */`` comments, decimal integer
and floating-point literals (an optional ``f`` suffix), identifiers, and the operators of
§5.1. Each token carries the line of the source it came from, so that every refusal can name
the file, the line and the construct.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

from brdfkit.errors import FormatError

__all__ = ["Token", "refuse", "tokenize"]


@dataclass(frozen=True)
class Token:
    """One token: its ``kind`` (``"number"``, ``"name"``, ``"op"`` or ``"end"``), its text and
    the source line it came from."""

    kind: str
    text: str
    line: int


_TOKEN = re.compile(
    r"""
    (?P<space>[ \t\r\f\v]+)
    |(?P<comment>//[^\n]*|/\*.*?\*/)
    |(?P<number>(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?[fF]?(?![\w.]))
    |(?P<name>[A-Za-z_]\w*)
    |(?P<op>\+\+|--|\+=|-=|\*=|/=|==|!=|<=|>=|&&|\|\||\^\^|<<|>>|[-+*/%<>=!?:;,.(){}\[\]&|^~])
    """,
    re.VERBOSE | re.DOTALL,
)


def refuse(path: str, line: int, construct: str) -> FormatError:
    """The error for a construct the subset cannot express (or a syntax error), naming the
    file, the line and the construct."""
    return FormatError(path, f"GLSL: {construct}", offset=line, line=True)


def _source_lines(source: str | Iterable[tuple[int, str]]) -> list[tuple[int, str]]:
    if isinstance(source, str):
        return list(enumerate(source.splitlines(), 1))
    return list(source)


def tokenize(source: str | Iterable[tuple[int, str]], path: str) -> list[Token]:
    """The tokens of ``source`` (a string, or ``(line number, text)`` pairs) ending in an
    ``"end"`` token, with ``#define NAME value`` constants expanded where they are used.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming ``path`` and the line, for a character outside GLSL, an unterminated comment,
        a function-like macro or another preprocessor directive.

    Examples
    --------
    >>> [t.text for t in tokenize("#define K 2.5\\nfloat x = K*.5f; // half", "demo.glsl")]
    ['float', 'x', '=', '2.5', '*', '.5f', ';', '']
    """
    lines = _source_lines(source)
    macros: dict[str, list[Token]] = {}
    body: list[tuple[int, str]] = []
    for number, text in lines:
        if text.lstrip().startswith("#"):
            name, value = _directive(text.strip(), number, path)
            macros[name] = _scan([(number, value)], path)
            body.append((number, ""))
        else:
            body.append((number, text))
    tokens = _expand(_scan(body, path), macros, path)
    return [*tokens, Token("end", "", lines[-1][0] if lines else 1)]


def _directive(text: str, line: int, path: str) -> tuple[str, str]:
    match = re.fullmatch(r"#\s*define\s+([A-Za-z_]\w*)(\(?)\s*(.*)", text)
    if match is None:
        word = re.match(r"#\s*(\w*)", text)
        raise refuse(path, line, f"preprocessor directive '#{word.group(1) if word else ''}'")
    if match.group(2):
        raise refuse(path, line, f"function-like macro '{match.group(1)}(…)'")
    return match.group(1), match.group(3)


def _scan(lines: list[tuple[int, str]], path: str) -> list[Token]:
    """Tokens of the lines joined, each given the source line it starts on."""
    text = "\n".join(t for _, t in lines)
    numbers = [n for n, _ in lines]
    tokens: list[Token] = []
    row, position = 0, 0
    while position < len(text):
        if text[position] == "\n":
            row, position = row + 1, position + 1
            continue
        if text.startswith("/*", position) and "*/" not in text[position + 2 :]:
            raise refuse(path, numbers[row], "unterminated comment")
        match = _TOKEN.match(text, position)
        if match is None:
            raise refuse(path, numbers[row], f"unexpected character {text[position]!r}")
        if match.lastgroup in ("number", "name", "op"):
            tokens.append(Token(match.lastgroup, match.group(), numbers[row]))
        row += match.group().count("\n")
        position = match.end()
    return tokens


def _expand(tokens: list[Token], macros: dict[str, list[Token]], path: str) -> list[Token]:
    """``tokens`` with every macro name replaced by its value (recursively, at the line of
    use)."""
    out: list[Token] = []

    def splice(token: Token, active: tuple[str, ...]) -> None:
        if token.kind != "name" or token.text not in macros:
            out.append(token)
            return
        if token.text in active:
            raise refuse(path, token.line, f"macro '{token.text}' that expands to itself")
        for inner in macros[token.text]:
            splice(Token(inner.kind, inner.text, token.line), (*active, token.text))

    for token in tokens:
        splice(token, ())
    return out
