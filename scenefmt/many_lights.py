"""How many lights a scene has once its instances are expanded, and whether a light tree pays.

A light tree (renderer/light_tree.py) chooses a light by what it may send to the shading point;
with few lights the choice by power is as good and costs less. The renderer builds the tree, and
`scenefmt.effects` switches on the kernels' path for it (`light_tree`), both by `wants_light_tree`
here, so the kernel that has the path and the tables that feed it agree.

Counted from the node graph alone (pure Python, no numpy), as `rt validate` needs: each emitting
primitive once per placement of its group (a mesh's triangles each, a box once), and each point
and spot light. Lights at infinity (the sun, directional lights, the map) are never in the tree.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from .materials import emits
from .scene import LIGHT_SAMPLING_INTEGRATORS

# A light tree is built, and compiled in, from this many lights on: below it the power cdf is
# chosen. Measured on floors lit by N small shaded lamps (benchmarks/light_tree.py --threshold;
# docs/lights.md), two runs: the power cdf's error at equal time over the tree's was 1.01-1.02 at
# 2 lamps and 1.02-1.07 at 4 (a tie), 1.72-1.76 at 8, 2.0 at 16 and 2.1 to 2.5 from 32 on.
LIGHT_TREE_THRESHOLD = 8
# The kinds of `lights:` entries that have a place, and so go into the tree.
PLACED_LIGHT_TYPES = ("point", "spot")


@dataclass(frozen=True)
class LightCount:
    total: int  # emitting primitives times their placements, plus point and spot lights
    reason: str  # where most of them come from, in words

    def __str__(self) -> str:
        return self.reason


def _own_lights(member) -> int:
    """Light rows an emitting shape or run adds to its group (an instance: none of its own)."""
    kind = member.kind
    if kind == "instance":
        return 0
    if kind == "sphere_run":
        return sum(count for material, count in zip(member.materials, member.material_count.tolist()) if emits(material.model))
    if member.material is None or not emits(member.material.model):
        return 0
    if kind == "mesh":
        return len(member.mesh.faces) if member.mesh is not None else 0
    return 1


def count_lights(graph) -> LightCount:
    """The scene's lights that a tree would hold, and the group that places most of them."""
    # Groups in an order where every group comes before the groups it places (depth first,
    # reversed post-order), then how many times each is placed, parents first.
    order: list = []
    seen: set = set()
    stack = [(graph.root, False)]
    while stack:
        group, done = stack.pop()
        if done:
            order.append(group)
            continue
        if id(group) in seen:
            continue
        seen.add(id(group))
        stack.append((group, True))
        for member in group.members:
            if member.kind == "instance" and id(member.group) not in seen:
                stack.append((member.group, False))
    order.reverse()
    placed = {id(graph.root): 1}
    for group in order:
        times = placed.get(id(group), 0)
        for member in group.members:
            if member.kind == "instance":
                placed[id(member.group)] = placed.get(id(member.group), 0) + times
    total = 0
    biggest: tuple[int, Optional[object], int] = (0, None, 0)  # (lights, group, its own lights)
    for group in order:
        own = sum(_own_lights(member) for member in group.members)
        lights = own * placed.get(id(group), 0)
        total += lights
        if lights > biggest[0]:
            biggest = (lights, group, own)
    placed_lights = sum(1 for light in getattr(graph, "lights", ()) or () if getattr(light, "type", None) in PLACED_LIGHT_TYPES)
    total += placed_lights
    lights, group, own = biggest
    if group is None or lights == 0:
        reason = f"{total:,} point and spot lights" if placed_lights else "no lights"
    elif group is graph.root:
        reason = f"{total:,} lights: {own:,} emitting shapes"
    else:
        times = lights // own
        reason = f"{total:,} lights: group {group.name} ({own:,} {'light' if own == 1 else 'lights'}) placed {times:,} times"
        if lights < total:
            reason += f" and {total - lights:,} more"
    return LightCount(total, reason)


def wants_light_tree(graph, count: Optional[LightCount] = None) -> bool:
    """Whether the renderer builds a light tree for `graph` and compiles its path: lights are
    sampled (integrator mis or guided) and there are at least LIGHT_TREE_THRESHOLD of them."""
    if graph.image.integrator not in LIGHT_SAMPLING_INTEGRATORS:
        return False
    count = count if count is not None else count_lights(graph)
    return count.total >= LIGHT_TREE_THRESHOLD
