"""A translator of the GLSL subset that analytic BRDF files are written in, to array code.

GLSL source is tokenized (:mod:`~brdfkit.interop.glsl.lexer`), parsed by recursive descent into
a syntax tree (:mod:`~brdfkit.interop.glsl.syntax`) and evaluated over arrays of the library's
namespace (:mod:`~brdfkit.interop.glsl.interpreter`), one lane per direction: never executed as
Python. The subset (the OpenGL Shading Language 4.10 [1]_ restricted to what the shaders of
Disney's BRDF Explorer [2]_ use):

- types ``float``, ``int``, ``bool``, ``vec2``, ``vec3``, ``vec4``; constructors; swizzles
  (``v.xyz``, ``v.rgb``) and constant indices (``v[0]``), read and written;
- functions with ``in`` parameters, returning a value or ``void``; global ``const``, plain and
  ``uniform`` declarations; object-like ``#define NAME value`` constants;
- the arithmetic, relational, equality and logical operators, ``?:``, compound assignment
  (``+=`` …), ``++``/``--`` as statements;
- ``if``/``else``, ``return`` anywhere, ``for`` loops whose condition is the same for every
  direction;
- the built-ins of :data:`~brdfkit.interop.glsl.builtins.BUILTINS` (trigonometry, exponentials,
  ``min``/``max``/``clamp``/``mix``/``step``/``smoothstep``, ``mod``/``fract``/``floor``,
  ``dot``/``cross``/``length``/``normalize``/``reflect``/``refract`` …).

Everything else (matrices, arrays, structs, ``while``, ``break``, ``out`` parameters,
textures, other preprocessor directives) is refused with a
:class:`~brdfkit.errors.FormatError` naming the file, the line and the construct.

References
----------
.. [1] J. Kessenich, D. Baldwin, R. Rost, *The OpenGL Shading Language*, version 4.10, 2010.
.. [2] B. Burley, "Physically-based shading at Disney", SIGGRAPH 2012 course notes; Walt Disney
       Animation Studios, *BRDF Explorer* (github.com/wdas/brdf), 2012.

Examples
--------
>>> import numpy as np
>>> program = translate('''
... #define SCALE 2.0
... float twice_length(vec3 v) { return SCALE * length(v); }''')
>>> x = np.array([3.0, 0.0])
>>> v = Value("vec3", (x, 4.0 + 0 * x, 0 * x))
>>> run(program, "twice_length", [v], {}, like=x).parts[0]
array([10.,  8.])
"""

from __future__ import annotations

from collections.abc import Iterable

from brdfkit.interop.glsl.builtins import BUILTINS
from brdfkit.interop.glsl.interpreter import check_calls, run
from brdfkit.interop.glsl.syntax import Program, parse
from brdfkit.interop.glsl.values import Value

__all__ = ["BUILTINS", "Program", "Value", "run", "translate"]


def translate(source: str | Iterable[tuple[int, str]], path: str = "<glsl>") -> Program:
    """The checked syntax tree of GLSL ``source`` (a string, or ``(line number, text)``
    pairs whose numbers the errors name): parsed, and every call resolved to a function of
    the source, a built-in or a constructor.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming ``path``, the line and the construct the subset cannot express.
    """
    program = parse(source, path)
    check_calls(program)
    return program
