r"""Unconstrained coordinates for parameters confined to an interval.

A least-squares fit moves its parameters freely; a model refuses a parameter outside its
domain (:class:`brdfkit.params.Domain`). Fitting in unconstrained coordinates :math:`u \in
\mathbb{R}` mapped into the domain :math:`x \in [l, h]` keeps every step of the optimiser a
valid model by construction, where bounds on :math:`x` (scipy's trust-region reflective) hold only
the box and a joint condition between parameters (Lafortune's peak :math:`\max|C|^n \le 10^{12}`)
is left to be refused halfway. The maps (the classic transformations of bounded problems to
unbounded ones, Box 1966; the logistic and log links of statistics):

- :math:`[l, h]`: :math:`x = l + (h - l)\,\sigma(u)`, :math:`\sigma(u) = 1/(1 + e^{-u})`;
  on a positive range of the domain's ``log`` scale (roughness, exponents),
  :math:`\ln x = \ln l + (\ln h - \ln l)\,\sigma(u)`;
- :math:`[l, \infty)`: :math:`x = l + e^u`; :math:`(-\infty, h]`: :math:`x = h - e^{-u}`;
- :math:`\mathbb{R}`: :math:`x = u`.

Each is smooth and strictly monotone: the fit's minimum inside the domain is a minimum in
:math:`u`, and one at a bound is approached as :math:`|u| \to \infty`. Near a lower bound
:math:`l = 0` of a wide range (a colour in :math:`[0, 10^6]`) the logistic map is the log map
:math:`x \approx h e^u`: a relative step in :math:`x` per unit of :math:`u`.

References
----------
.. [1] M. J. Box, "A comparison of several current optimization methods, and the use of
       transformations in constrained problems", The Computer Journal 9(1), 67–77, 1966.
.. [2] P. McCullagh, J. A. Nelder, *Generalized Linear Models*, 2nd ed., Chapman & Hall, 1989
       (the logit and log links).
"""

from __future__ import annotations

import numpy as np
from scipy.special import expit, logit

INTERIOR = 1e-9
"""How far inside a finite range :func:`unconstrained` moves a value on (or beyond) its end,
relative to the range (at most 1): the map's end itself is at :math:`u = \\pm\\infty`."""

_LARGEST_EXPONENT = 700.0
"""The largest :math:`u` of a half-open range's :math:`e^u` (:math:`e^{700} \\approx 10^{304}`,
short of overflow)."""


def _cases(lower: np.ndarray, upper: np.ndarray, log: np.ndarray) -> dict[str, np.ndarray]:
    """Masks of the entries by the kind of their range."""
    lo, hi = np.isfinite(lower), np.isfinite(upper)
    logs = lo & hi & log & (lower > 0)
    return {
        "log": logs,
        "box": lo & hi & ~logs,
        "above": lo & ~hi,
        "below": ~lo & hi,
        "free": ~lo & ~hi,
    }


def _broadcast(*arrays: np.ndarray | float | bool) -> list[np.ndarray]:
    return [np.array(a) for a in np.broadcast_arrays(*(np.asarray(a) for a in arrays))]


def constrained(
    u: np.ndarray, lower: np.ndarray, upper: np.ndarray, log: np.ndarray | bool = False
) -> np.ndarray:
    """The values :math:`x` in ``[lower, upper]`` of the unconstrained coordinates ``u``
    (module docstring), entry by entry; ``log`` marks the ranges mapped on a log scale.

    Examples
    --------
    >>> import numpy as np
    >>> x = constrained(np.array([-50.0, 0.0, 50.0, 0.0]), [0, 0, 0, 1e-3], [1, 1, 1, 10],
    ...                 [False, False, False, True])
    >>> np.round(x, 6).tolist()
    [0.0, 0.5, 1.0, 0.1]
    """
    u, lower, upper, log = _broadcast(u, lower, upper, log)
    x = np.array(u, dtype=np.float64)
    cases = _cases(lower, upper, log.astype(bool))
    m = cases["box"]
    x[m] = lower[m] + (upper[m] - lower[m]) * expit(u[m])
    m = cases["log"]
    x[m] = np.exp(np.log(lower[m]) + np.log(upper[m] / lower[m]) * expit(u[m]))
    m = cases["above"]
    x[m] = lower[m] + np.exp(np.minimum(u[m], _LARGEST_EXPONENT))
    m = cases["below"]
    x[m] = upper[m] - np.exp(np.minimum(-u[m], _LARGEST_EXPONENT))
    return np.clip(x, lower, upper)  # the rounding of l + (h - l)·σ(u) stays inside


def unconstrained(
    x: np.ndarray, lower: np.ndarray, upper: np.ndarray, log: np.ndarray | bool = False
) -> np.ndarray:
    """The unconstrained coordinates ``u`` of the values ``x`` (the inverse of
    :func:`constrained`); a value on or beyond an end of its range is first moved
    :data:`INTERIOR` of the range inside it.

    Examples
    --------
    >>> import numpy as np
    >>> lower, upper, log = [0.0, 1e-4, 0.0, -np.inf], [1.0, 10.0, np.inf, np.inf], [0, 1, 0, 0]
    >>> x = np.array([0.25, 0.3, 2.0, -7.0])
    >>> np.allclose(constrained(unconstrained(x, lower, upper, log), lower, upper, log), x)
    True
    >>> float(unconstrained(np.array([0.0]), [0.0], [1.0])[0]) > -21  # an end: moved inside
    True
    """
    x, lower, upper, log = _broadcast(x, lower, upper, log)
    x = np.array(x, dtype=np.float64)
    cases = _cases(lower, upper, log.astype(bool))
    finite = cases["box"] | cases["log"]
    margin = INTERIOR * np.minimum(np.where(finite, upper - lower, 1.0), 1.0)
    x = np.clip(x, lower + margin, upper - margin)
    u = np.array(x)
    m = cases["box"]
    u[m] = logit((x[m] - lower[m]) / (upper[m] - lower[m]))
    m = cases["log"]
    u[m] = logit(np.log(x[m] / lower[m]) / np.log(upper[m] / lower[m]))
    m = cases["above"]
    u[m] = np.log(x[m] - lower[m])
    m = cases["below"]
    u[m] = -np.log(upper[m] - x[m])
    return u


def coordinate_bounds(
    lower: np.ndarray, upper: np.ndarray, log: np.ndarray | bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The coordinates of the ends of each range, each moved :data:`INTERIOR` inside it
    (:math:`\\pm\\infty` for an open end): where a fit stops a parameter that wants its end.

    Every map is increasing, so the ends bound the coordinates: without them a parameter whose
    best value is its end (a colour channel at 0) walks towards :math:`u = -\\infty`, a step of
    the optimiser at a time, changing the model less and less.

    Examples
    --------
    >>> low, high = coordinate_bounds([0.0, 0.0], [1.0, np.inf])
    >>> constrained(low, [0.0, 0.0], [1.0, np.inf]).round(12).tolist(), high.round(3).tolist()
    ([1e-09, 1e-09], [20.723, inf])
    """
    lower, upper, log = _broadcast(lower, upper, log)
    lower, upper = lower.astype(np.float64), upper.astype(np.float64)
    ends = [np.full(lower.shape, -np.inf), np.full(lower.shape, np.inf)]
    for side, end in enumerate((lower, upper)):
        finite = np.isfinite(end)
        ends[side][finite] = unconstrained(end[finite], lower[finite], upper[finite], log[finite])
    return ends[0], ends[1]


__all__ = ["INTERIOR", "constrained", "coordinate_bounds", "unconstrained"]
