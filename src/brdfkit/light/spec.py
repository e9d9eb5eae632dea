"""Light specs: the short strings that name a light on the command line.

``"directional:1,0.5,0.7:3"``, ``"point:0,0,2:10"``, ``"sky:1"``, ``"envmap:sky.hdr"``,
``"sunsky:0,1,1:3"``; :data:`LIGHT_SPECS` lists the forms and :func:`parse_light` reads one.
"""

from __future__ import annotations

from brdfkit.errors import SpecError
from brdfkit.light.analytic import DirectionalLight, PointLight, UniformSky
from brdfkit.light.base import STRENGTH, Light
from brdfkit.light.environment import EnvironmentMap

# --------------------------------------------------------------------------- light specs
LIGHT_SPECS = {
    "directional": "directional:X,Y,Z[:E]  (direction towards the light, irradiance E)",
    "point": "point:X,Y,Z[:I]  (position, intensity I)",
    "sky": "sky[:L]  (uniform radiance L over the upper hemisphere)",
    "envmap": "envmap:PATH[:SCALE]  (lat-long .hdr/.exr; 'envmap' alone: the bundled map)",
    "sunsky": "sunsky:X,Y,Z[:T]  (Hosek–Wilkie sky and sun towards X,Y,Z, turbidity T)",
}


def parse_light(spec: str) -> Light:
    """A light from a short text spec, e.g. ``"directional:1,0.5,0.7:3"`` or ``"envmap:sky.hdr"``.

    The forms are :data:`LIGHT_SPECS`; numbers are read with :class:`float`, and a spec holds at
    most :data:`~brdfkit.params.MAX_SPEC_LENGTH` characters. An environment map's file is
    read by :func:`brdfkit.io.read_image`, whose errors pass through.

    Raises
    ------
    brdfkit.errors.SpecError
        For a spec outside these forms (an unknown kind, a missing or malformed number), naming
        the spec and listing the known forms.
    brdfkit.errors.ParameterError
        For a value outside its domain (a zero or non-finite direction, a negative or infinite
        strength), naming it.

    Examples
    --------
    >>> light = parse_light("directional:0,0,2:3")
    >>> type(light).__name__, light.direction.tolist(), light.irradiance
    ('DirectionalLight', [0.0, 0.0, 1.0], 3.0)
    >>> parse_light("point:0,0,2:10").intensity, parse_light("sky:0.5").radiance
    (10.0, 0.5)
    >>> parse_light("laser:1")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.SpecError: light spec 'laser:1' has an unknown kind 'laser'. Known forms: ...
    """
    from brdfkit.params import MAX_SPEC_LENGTH

    if not isinstance(spec, str):
        raise SpecError(f"light spec must be a string; got {type(spec).__name__} {spec!r:.80}")
    if len(spec) > MAX_SPEC_LENGTH:
        raise SpecError(f"light spec holds {len(spec)} characters; at most {MAX_SPEC_LENGTH}")
    kind, _, rest = spec.strip().partition(":")
    if kind in ("directional", "point"):
        vector, _, value = rest.partition(":")
        numbers = _floats(spec, vector, 3), _float(spec, value or "1")
        if kind == "directional":
            return DirectionalLight(*numbers)
        return PointLight(*numbers)
    if kind == "sky":
        return UniformSky(_float(spec, rest or "1"))
    if kind == "envmap":
        path, scale = rest, 1.0
        head, sep, tail = rest.rpartition(":")
        if sep and _is_float(tail):
            path, scale = head, float(tail)
        STRENGTH.check("scale", scale)  # before the file is read
        if not path:
            from brdfkit.data import default_envmap_path

            path = str(default_envmap_path())
        return EnvironmentMap.from_file(path, scale=scale)
    if kind == "sunsky":
        from brdfkit.light.sunsky import SunSky

        vector, _, value = rest.partition(":")
        return SunSky(_floats(spec, vector, 3), turbidity=_float(spec, value or "3"))
    raise SpecError(f"light spec {spec!r:.80} has an unknown kind {kind!r:.40}. {_known()}")


def _known() -> str:
    return f"Known forms: {'; '.join(LIGHT_SPECS.values())}"


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _float(spec: str, text: str) -> float:
    """``text`` as a float, or a :class:`~brdfkit.errors.SpecError` quoting ``spec``."""
    if not _is_float(text):
        raise SpecError(
            f"light spec {spec!r:.80} is invalid: {text!r:.40} is no number. {_known()}"
        )
    return float(text)


def _floats(spec: str, text: str, count: int) -> tuple[float, ...]:
    """``count`` comma-separated floats, or a :class:`~brdfkit.errors.SpecError`."""
    parts = text.split(",")
    if len(parts) != count:
        raise SpecError(
            f"light spec {spec!r:.80} is invalid: expected {count} comma-separated numbers, got "
            f"{text!r:.40}. {_known()}"
        )
    return tuple(_float(spec, part) for part in parts)


__all__ = [
    "LIGHT_SPECS",
    "parse_light",
]
