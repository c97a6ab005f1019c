"""The CAD parts of the FEM data sets: OpenCASCADE solids through gmsh, with through-holes and internal voids."""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np



# ------------------------------------------------------------ CAD parts
@dataclasses.dataclass(frozen=True)
class _Part:
    """A mechanical-looking part: OCC construction, topology, heat-problem set-up."""

    name: str
    description: str
    genus: int  # of the outer surface, as the construction implies
    n_voids: int
    build: Callable  # (occ) -> volume tag; creates the solid in the current model
    # Dirichlet patches: (predicate on (3, N) coordinates true only on boundary nodes, value)
    patches: tuple


def _on_plane(axis, value):
    return lambda x: np.abs(x[axis] - value) < 1e-6


def _on_cylinder(axis, centre, radius, where=None):
    a, b = [i for i in range(3) if i != axis]

    def test(x):
        on = np.abs(np.hypot(x[a] - centre[0], x[b] - centre[1]) - radius) < 1e-6
        return on if where is None else on & where(x)

    return test


def _cut(occ, base, tools):
    out, _ = occ.cut([(3, base)], [(3, t) for t in tools])
    if len(out) != 1:  # pragma: no cover - the constructions below give one solid
        raise RuntimeError(f"OCC cut gave {len(out)} solids")
    return out[0][1]


def _fuse(occ, tags):
    out, _ = occ.fuse([(3, tags[0])], [(3, t) for t in tags[1:]])
    if len(out) != 1:  # pragma: no cover
        raise RuntimeError(f"OCC fuse gave {len(out)} solids")
    return out[0][1]


def _bracket(occ):
    # 4 x 2 x 1 block, two vertical bolt holes, a spherical void between them
    box = occ.addBox(0, 0, 0, 4, 2, 1)
    holes = [occ.addCylinder(x, 1, -1, 0, 0, 3, 0.4) for x in (1.0, 3.0)]
    void = occ.addSphere(2, 1, 0.5, 0.3)
    return _cut(occ, box, holes + [void])


def _flange(occ):
    # disc r = 2, thickness 0.8, central bore, four bolt holes; a spherical and a box void
    disc = occ.addCylinder(0, 0, 0, 0, 0, 0.8, 2.0)
    bore = occ.addCylinder(0, 0, -1, 0, 0, 3, 0.6)
    bolts = [
        occ.addCylinder(1.4 * np.cos(t), 1.4 * np.sin(t), -1, 0, 0, 3, 0.2)
        for t in np.deg2rad([0.0, 90.0, 180.0, 270.0])
    ]
    c = np.cos(np.pi / 4)
    sphere = occ.addSphere(1.0 * c, 1.0 * c, 0.4, 0.15)
    box = occ.addBox(-1.0 * c - 0.15, -1.0 * c - 0.15, 0.25, 0.3, 0.3, 0.3)
    return _cut(occ, disc, [bore] + bolts + [sphere, box])


def _pillow_block(occ):
    # base plate with two bolt holes, a pedestal and a round boss with a bearing bore along y;
    # a spherical void under the bore and a box void in the base
    base = occ.addBox(0, 0, 0, 6, 2, 0.8)
    pedestal = occ.addBox(1.6, 0, 0, 2.8, 2, 1.6)
    boss = occ.addCylinder(3, 0, 1.6, 0, 2, 0, 1.4)
    body = _fuse(occ, [base, pedestal, boss])
    bore = occ.addCylinder(3, -1, 1.6, 0, 4, 0, 0.7)
    bolts = [occ.addCylinder(x, 1, -1, 0, 0, 3, 0.3) for x in (0.8, 5.2)]
    sphere = occ.addSphere(3, 1, 0.45, 0.25)
    box = occ.addBox(4.3, 0.2, 0.25, 0.4, 0.4, 0.3)
    return _cut(occ, body, [bore] + bolts + [sphere, box])


def _manifold(occ):
    # 4 x 4 x 3 block; a bore along x crossing a bore along y (genus 3 together), a vertical
    # bolt hole (genus 1 more); two spherical voids
    block = occ.addBox(0, 0, 0, 4, 4, 3)
    bx = occ.addCylinder(-1, 2, 1.5, 6, 0, 0, 0.5)
    by = occ.addCylinder(2, -1, 1.5, 0, 6, 0, 0.5)
    bolt = occ.addCylinder(0.8, 0.8, -1, 0, 0, 5, 0.3)
    s1 = occ.addSphere(3, 3, 0.75, 0.4)
    s2 = occ.addSphere(3, 3, 2.4, 0.3)
    return _cut(occ, block, [bx, by, bolt, s1, s2])


def _angle_bracket(occ):
    # L-shaped bracket: a horizontal plate with two bolt holes, an upright with a bore along x;
    # a spherical void in the upright
    plate = occ.addBox(0, 0, 0, 5, 3, 0.8)
    upright = occ.addBox(0, 0, 0, 0.8, 3, 4)
    body = _fuse(occ, [plate, upright])
    bolts = [occ.addCylinder(x, 1.5, -1, 0, 0, 3, 0.35) for x in (2.5, 4.0)]
    bore = occ.addCylinder(-1, 1.5, 2.5, 3, 0, 0, 0.5)
    void = occ.addSphere(0.4, 1.5, 1.4, 0.2)
    return _cut(occ, body, bolts + [bore, void])


@dataclasses.dataclass(frozen=True)
class _ExtrudedPart:
    """A part made by stacking a cross-section (with holes) in layers, with prism voids inside."""

    name: str
    description: str
    genus: int
    n_voids: int
    build: Callable  # (occ) -> (section face tag, [void footprint face tags])
    thickness: float
    void_z: tuple  # (z0, z1) of each footprint's void
    patches: tuple


def _plate_section(occ):
    # the bracket's cross-section: two bolt holes; a round void footprint between them
    rect = occ.addRectangle(0, 0, 0, 4, 2)
    holes = [occ.addDisk(x, 1, 0, 0.4, 0.4) for x in (1.0, 3.0)]
    out, _ = occ.cut([(2, rect)], [(2, d) for d in holes])
    return out[0][1], [occ.addDisk(2, 1, 0, 0.3, 0.3)]


def _flange_section(occ):
    disc = occ.addDisk(0, 0, 0, 2.0, 2.0)
    cuts = [occ.addDisk(0, 0, 0, 0.6, 0.6)] + [
        occ.addDisk(1.4 * np.cos(t), 1.4 * np.sin(t), 0, 0.2, 0.2) for t in np.deg2rad([0.0, 90.0, 180.0, 270.0])
    ]
    out, _ = occ.cut([(2, disc)], [(2, d) for d in cuts])
    c = np.cos(np.pi / 4)
    return out[0][1], [occ.addDisk(c, c, 0, 0.15, 0.15), occ.addRectangle(-c - 0.15, -c - 0.15, 0, 0.3, 0.3)]


def _base_plate_section(occ):
    rect = occ.addRectangle(0, 0, 0, 6, 3)
    holes = [occ.addDisk(x, 1.5, 0, 0.35, 0.35) for x in (1.0, 3.0, 5.0)]
    out, _ = occ.cut([(2, rect)], [(2, d) for d in holes])
    return out[0][1], [occ.addDisk(2.0, 0.6, 0, 0.25, 0.25), occ.addRectangle(3.8, 2.1, 0, 0.4, 0.4)]


_PARTS = {
    "bracket": _Part(
        "bracket",
        "a 4x2x1 block with two bolt holes and a spherical void",
        2,
        1,
        _bracket,
        ((_on_cylinder(2, (1.0, 1.0), 0.4), 0.0), (_on_plane(0, 4.0), 1.0)),
    ),
    "flange": _Part(
        "flange",
        "a round flange with a central bore, four bolt holes, a spherical and a box void",
        5,
        2,
        _flange,
        ((_on_cylinder(2, (0.0, 0.0), 0.6), 0.0), (_on_cylinder(2, (0.0, 0.0), 2.0, lambda x: x[0] > 1.2), 1.0)),
    ),
    "pillow_block": _Part(
        "pillow_block",
        "a pillow block: base with two bolt holes, a boss with a bearing bore, two voids",
        3,
        2,
        _pillow_block,
        ((_on_cylinder(1, (3.0, 1.6), 0.7), 1.0), (_on_cylinder(2, (0.8, 1.0), 0.3), 0.0), (_on_plane(0, 6.0), 0.0)),
    ),
    "manifold": _Part(
        "manifold",
        "a manifold block with two crossing bores, a bolt hole and two spherical voids",
        4,
        2,
        _manifold,
        ((_on_cylinder(0, (2.0, 1.5), 0.5), 1.0), (_on_plane(2, 0.0), 0.0), (_on_cylinder(2, (0.8, 0.8), 0.3), 0.5)),
    ),
    "angle_bracket": _Part(
        "angle_bracket",
        "an angle bracket: a plate with two bolt holes, an upright with a bore, a spherical void",
        3,
        1,
        _angle_bracket,
        ((_on_cylinder(0, (1.5, 2.5), 0.5), 1.0), (_on_plane(0, 5.0), 0.0)),
    ),
    "plate": _ExtrudedPart(
        "plate",
        "a 4x2x1 plate with two bolt holes and a cylindrical void (extruded hexahedra)",
        2,
        1,
        _plate_section,
        1.0,
        ((0.3, 0.7),),
        ((_on_cylinder(2, (1.0, 1.0), 0.4), 0.0), (_on_plane(0, 4.0), 1.0)),
    ),
    "flange_hex": _ExtrudedPart(
        "flange_hex",
        "a round flange with a central bore, four bolt holes, a cylindrical and a box void (extruded hexahedra)",
        5,
        2,
        _flange_section,
        0.8,
        ((0.25, 0.55), (0.25, 0.55)),
        ((_on_cylinder(2, (0.0, 0.0), 0.6), 0.0), (_on_cylinder(2, (0.0, 0.0), 2.0, lambda x: x[0] > 1.2), 1.0)),
    ),
    "base_plate": _ExtrudedPart(
        "base_plate",
        "a 6x3x1.2 base plate with three bolt holes, a cylindrical and a box void (extruded hexahedra)",
        3,
        2,
        _base_plate_section,
        1.2,
        ((0.4, 0.8), (0.4, 0.8)),
        ((_on_cylinder(2, (1.0, 1.5), 0.35), 0.0), (_on_plane(0, 6.0), 1.0)),
    ),
}
