"""Whether corners given in a scenario make a simple polygon (docs/contract.md §4 footprints, station areas).

A footprint or a station area is a polygon, and the geometry behind collisions and reach (shapely, GEOS)
is defined for valid polygons only: a self-crossing footprint (a bow tie, a pentagram), one with no area
or one whose outline runs back along itself made GEOS raise ``TopologyException`` in the middle of a
run (exit 70) the first time two robots touched. The loader asks :func:`polygon_problem` instead, so such
a file fails to load with a message naming the field.

Plain Python, exact: the orientation tests run on :class:`fractions.Fraction` (a float converts to one
exactly), so "touching" is decided without rounding, and only for edges whose boxes meet. A corner given
twice in a row (the first repeated at the end, as some tools close a ring) counts once.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from functools import lru_cache

Point = tuple[float, float]


def polygon_problem(points: Sequence[Point]) -> str | None:
    """Why ``points`` (in order round the outline) are not a simple polygon with an area, or None."""
    return _problem(tuple((float(x), float(y)) for x, y in points))


@lru_cache(maxsize=256)  # a fleet's robots mostly share one footprint
def _problem(points: tuple[Point, ...]) -> str | None:
    corners = [p for i, p in enumerate(points) if p != points[i - 1]] if len(set(points)) > 1 else list(points[:1])
    n = len(corners)
    if n < 3:
        return f"a polygon needs at least 3 different corners, got {n}"
    exact = [(Fraction(x), Fraction(y)) for x, y in corners]
    edges = [(exact[i], exact[(i + 1) % n]) for i in range(n)]
    for i in range(n):  # an outline running straight back along itself (a spike)
        (a, b), (_, c) = edges[i], edges[(i + 1) % n]
        if _side(a, b, c) == 0 and _dot(a, b, c) < 0:
            return f"its outline runs back along itself at corner {(i + 1) % n} {_show(corners[(i + 1) % n])}"
    boxes = [(min(a[0], b[0]), min(a[1], b[1]), max(a[0], b[0]), max(a[1], b[1])) for a, b in edges]
    for i in range(n):
        for j in range(i + 2, n - 1 if i == 0 else n):  # edges that share no corner
            bi, bj = boxes[i], boxes[j]
            if bi[0] > bj[2] or bj[0] > bi[2] or bi[1] > bj[3] or bj[1] > bi[3]:
                continue
            if _meet(*edges[i], *edges[j]):
                return (f"its edges {_show(corners[i])}-{_show(corners[(i + 1) % n])} and "
                        f"{_show(corners[j])}-{_show(corners[(j + 1) % n])} cross or touch: not a simple polygon")
    area = sum(a[0] * b[1] - b[0] * a[1] for a, b in edges)
    if area == 0:
        return "it has no area (its corners lie on one line)"
    return None


def _dot(a: tuple[Fraction, Fraction], b: tuple[Fraction, Fraction], c: tuple[Fraction, Fraction]) -> Fraction:
    return (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1])


def _side(a: tuple[Fraction, Fraction], b: tuple[Fraction, Fraction], c: tuple[Fraction, Fraction]) -> int:
    """The turn a, b, c: 1 left, -1 right, 0 on one line (the sign of twice the triangle's signed area)."""
    v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    return (v > 0) - (v < 0)


def _on(a: tuple[Fraction, Fraction], b: tuple[Fraction, Fraction], p: tuple[Fraction, Fraction]) -> bool:
    """``p``, on the line through a and b, lies on the segment a-b."""
    return min(a[0], b[0]) <= p[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])


def _meet(a: tuple[Fraction, Fraction], b: tuple[Fraction, Fraction],
          c: tuple[Fraction, Fraction], d: tuple[Fraction, Fraction]) -> bool:
    """Whether segments a-b and c-d have a point in common (touching counts)."""
    s1, s2, s3, s4 = _side(a, b, c), _side(a, b, d), _side(c, d, a), _side(c, d, b)
    if s1 * s2 < 0 and s3 * s4 < 0:
        return True
    return ((s1 == 0 and _on(a, b, c)) or (s2 == 0 and _on(a, b, d))
            or (s3 == 0 and _on(c, d, a)) or (s4 == 0 and _on(c, d, b)))


def _show(p: Point) -> str:
    return f"[{p[0]:g}, {p[1]:g}]"


def covers(points: Sequence[Point], x: float, y: float) -> bool:
    """Whether the simple polygon ``points`` holds ``(x, y)``, its outline included (shapely's ``covers``),
    decided exactly: on an edge, or an odd number of edges crossed by a ray to the right."""
    p = (Fraction(x), Fraction(y))
    exact = [(Fraction(a), Fraction(b)) for a, b in points]
    inside = False
    for i, a in enumerate(exact):
        b = exact[i - 1]
        if _side(a, b, p) == 0 and _on(a, b, p):
            return True
        if (a[1] > p[1]) != (b[1] > p[1]):  # the edge spans the ray's height: where does it cross?
            cross_x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
            inside ^= cross_x > p[0]
    return inside
