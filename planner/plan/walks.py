"""Walks over a rooted DAG given by a `children` function: the one implementation
that the plan (nodes by id) and the builder's DAG (nodes by state) share.

Iterative on purpose: plans of the larger families are thousands of nodes deep
in their unfolding, and recursion would hit Python's limit.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Hashable, Iterable
from typing import TypeVar

K = TypeVar("K", bound=Hashable)
Children = Callable[[K], Iterable[K]]


def breadth_first(root: K, children: Children[K]) -> list[K]:
    """Every node reachable from `root`, once, in breadth-first order."""
    seen: set[K] = set()
    order: list[K] = []
    queue = deque([root])
    while queue:
        node = queue.popleft()
        if node in seen:
            continue
        seen.add(node)
        order.append(node)
        queue.extend(children(node))
    return order


def postorder(root: K, children: Children[K]) -> list[K]:
    """Every node reachable from `root`, once, each after all of its children."""
    order: list[K] = []
    seen: set[K] = set()
    stack: list[tuple[K, bool]] = [(root, False)]
    while stack:
        node, expanded = stack.pop()
        if expanded:
            order.append(node)
            continue
        if node in seen:
            continue
        seen.add(node)
        stack.append((node, True))
        stack.extend((c, False) for c in reversed(list(children(node))))
    return order


def with_chains(root: K, children: Children[K], chain: Callable[[K], int]) -> list[tuple[K, int]]:
    """Breadth-first order of the DAG with a chain of `chain(node)` nodes put before
    each node: (node, i) for i < chain(node) is the chain's i-th, (node, chain(node))
    the node itself. An edge into a node enters its chain, which ends at the node."""

    def entry(node: K) -> tuple[K, int]:
        return node, 0

    def successors(key: tuple[K, int]) -> list[tuple[K, int]]:
        node, i = key
        if i < chain(node):
            return [(node, i + 1)]
        return [entry(c) for c in children(node)]

    return breadth_first(entry(root), successors)


def find_back_edge(root: K, children: Children[K]) -> tuple[K, K] | None:
    """An edge (node, child) that closes a loop: the child is on a path from `root`
    to the node (depth first, children in order), or None."""
    colour: dict[K, int] = {}  # 1: on the current path, 2: finished
    stack: list[tuple[K, list[K], int]] = [(root, list(children(root)), 0)]
    colour[root] = 1
    while stack:
        node, kids, i = stack.pop()
        if i < len(kids):
            stack.append((node, kids, i + 1))
            kid = kids[i]
            state = colour.get(kid)
            if state == 1:
                return node, kid
            if state is None:
                colour[kid] = 1
                stack.append((kid, list(children(kid)), 0))
        else:
            colour[node] = 2
    return None
