"""The Pareto front of cost (lower is better) against quality (higher is better)."""

from __future__ import annotations


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point dominates, by increasing cost.

    A point ``(cost, quality)`` is dominated when another has cost <= and quality >= with one of
    them strict.  Equal points are all on the front.
    """
    front = []
    for i, (c, q) in enumerate(points):
        dominated = any((c2 <= c and q2 >= q) and (c2 < c or q2 > q) for j, (c2, q2) in enumerate(points) if j != i)
        if not dominated:
            front.append(i)
    return sorted(front, key=lambda i: (points[i][0], -points[i][1]))
