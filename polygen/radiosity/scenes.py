"""Standard radiosity scenes: the Cornell box and the thesis's test scenes.

All polygons face the viewer-relevant side: room walls face inwards, solid
objects outwards, thin floating rectangles are two polygons back to back.
Where an object stands on a receiver (the Cornell box's blocks on the
floor, the chair's legs on the floor and its back on the seat), the
receiver is cut along the object's footprint and the object has no face
there: no light reaches the contact, and elements straddling it would
otherwise leak light.
"""

from __future__ import annotations

import numpy as np

from polygen.radiosity.scene import AreaLight, Polygon, Scene

__all__ = [
    "box_room",
    "cornell_box",
    "furnace_box",
    "unit_cube",
    "two_rectangles_room",
    "three_rectangles_box",
    "sphere_scene",
    "chair_scene",
    "figure_3_4_scene",
    "concave_occluder_scene",
    "small_shadows_room",
    "small_shadows_depth",
    "CORNELL_WHITE",
    "CORNELL_RED",
    "CORNELL_GREEN",
]

# RGB reflectances commonly used for the Cornell box (from its measured spectra)
CORNELL_WHITE = (0.725, 0.71, 0.68)
CORNELL_RED = (0.63, 0.065, 0.05)
CORNELL_GREEN = (0.14, 0.45, 0.091)
CORNELL_LIGHT = (17.0, 12.0, 4.0)


def _facing(vertices, toward, away=False):
    """Order the ring so that its right-hand normal points toward (or away from) a point."""
    v = np.asarray(vertices, dtype=np.float64)
    n = np.cross(np.roll(v, -1, axis=0), v).sum(axis=0) * -1.0  # Newell, right-hand
    s = n @ (np.asarray(toward, dtype=np.float64) - v.mean(axis=0))
    if (s < 0) != away:
        v = v[::-1]
    return v


def _box_faces(lo, hi):
    """The six rectangles of an axis-aligned box, each as a (4, 3) ring (unoriented)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    return {
        "x0": [[x0, y0, z0], [x0, y1, z0], [x0, y1, z1], [x0, y0, z1]],
        "x1": [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]],
        "y0": [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],
        "y1": [[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]],
        "z0": [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]],
        "z1": [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
    }


def _solid_box(lo, hi, *, reflectance, name, faces=("x0", "x1", "y0", "y1", "z0", "z1")):
    """Outward-facing faces of a solid box."""
    centre = 0.5 * (np.asarray(lo, float) + np.asarray(hi, float))
    rings = _box_faces(lo, hi)
    return [Polygon(_facing(rings[f], centre, away=True), reflectance=reflectance,
                    name=f"{name}_{f}") for f in faces]


def _rectangle(centre, size_u, size_v, axis_u, axis_v):
    c = np.asarray(centre, dtype=np.float64)
    u = np.asarray(axis_u, dtype=np.float64) * 0.5 * size_u
    v = np.asarray(axis_v, dtype=np.float64) * 0.5 * size_v
    return np.array([c - u - v, c + u - v, c + u + v, c - u + v])


def _two_sided(ring, *, reflectance, name):
    # a thin occluder: one polygon meshed on both faces (not two back-to-back polygons)
    return [Polygon(ring, reflectance=reflectance, name=name, two_sided=True)]


def box_room(size=(1.0, 1.0, 1.0), *, reflectance=0.5, emission=0.0, light=None, hole_for_light=True,
             floor_holes=(), name="box_room"):
    """The inside of an axis-aligned box [0, size], walls facing in; y is up.

    Parameters
    ----------
    size : (3,) float
    reflectance, emission : float or (3,) or dict face -> value, keyword-only
        Face keys ``x0, x1, y0 (floor), y1 (ceiling), z0, z1``.
    light : (4, 3) ring, keyword-only
        A convex light in the ceiling plane; the ceiling gets a hole there
        when ``hole_for_light``.
    floor_holes : sequence of (k, 3) float64, keyword-only
        Footprints of objects standing on the floor (y = 0): the floor is
        cut there, since no light reaches a receiver under an object.

    Returns
    -------
    list of Polygon
    """
    size = np.asarray(size, dtype=np.float64)
    centre = 0.5 * size
    rings = _box_faces(np.zeros(3), size)
    polys = []
    for f in ("y0", "y1", "x0", "x1", "z0", "z1"):
        rho = reflectance[f] if isinstance(reflectance, dict) else reflectance
        em = emission[f] if isinstance(emission, dict) else emission
        holes = []
        if f == "y1" and light is not None and hole_for_light:
            holes = [np.asarray(light, dtype=np.float64)]
        if f == "y0":
            holes = [np.asarray(h, dtype=np.float64) for h in floor_holes]
        polys.append(Polygon(_facing(rings[f], centre), holes, reflectance=rho, emission=em,
                             name=f"{name}_{f}"))
    return polys


def furnace_box(*, emission=1.0, reflectance=0.5, size=(1.0, 1.0, 1.0)):
    """A closed box whose six faces all emit and reflect: B = E / (1 - rho) everywhere."""
    return Scene(box_room(size, reflectance=reflectance, emission=emission, name="furnace"),
                 name="furnace_box")


def unit_cube(*, ceiling_emission=1.0, reflectance=0.5):
    """The inside of a unit cube, only the ceiling (y = 1) emitting."""
    em = {f: 0.0 for f in ("x0", "x1", "y0", "y1", "z0", "z1")}
    em["y1"] = ceiling_emission
    return Scene(box_room((1.0, 1.0, 1.0), reflectance=reflectance, emission=em, name="cube"),
                 name="unit_cube")


CORNELL_SHORT_TOP = ((130.0, 165.0, 65.0), (82.0, 165.0, 225.0), (240.0, 165.0, 272.0),
                     (290.0, 165.0, 114.0))
CORNELL_TALL_TOP = ((423.0, 330.0, 247.0), (265.0, 330.0, 296.0), (314.0, 330.0, 456.0),
                    (472.0, 330.0, 406.0))


def cornell_box(*, blocks=True, closed=False, light_emission=CORNELL_LIGHT):
    """The Cornell box, in millimetres, from the published Cornell geometry.

    Floor, ceiling (with a hole where the light is), back, left (red) and
    right (green) walls; the 130 x 105 light at y = 548.8 facing down; the
    short and the tall block.  The published left wall is not planar (one
    corner is 3.2 mm off the plane of the other three), so it is given as
    two triangles.  The blocks stand on the floor: the floor has holes
    where they stand (their footprints) and the blocks have no bottom
    faces, since no light reaches either.

    Parameters
    ----------
    blocks : bool, keyword-only
    closed : bool, keyword-only
        Close the front (z = 0) with a white wall, for furnace tests; the
        published box is open.
    light_emission : (3,) float, keyword-only

    Returns
    -------
    Scene
    """
    inside = np.array([278.0, 274.4, 279.6])
    tops = {"short_block": np.array(CORNELL_SHORT_TOP), "tall_block": np.array(CORNELL_TALL_TOP)}
    footprints = [t * [1.0, 0.0, 1.0] for t in tops.values()] if blocks else []
    light = np.array([[343.0, 548.8, 227.0], [343.0, 548.8, 332.0], [213.0, 548.8, 332.0],
                      [213.0, 548.8, 227.0]])
    light_ring = _facing(light, [278.0, 0.0, 279.6])
    polys = [
        Polygon(_facing([[552.8, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 559.2],
                         [549.6, 0.0, 559.2]], inside), footprints, reflectance=CORNELL_WHITE,
                name="floor"),
        Polygon(_facing([[556.0, 548.8, 0.0], [556.0, 548.8, 559.2], [0.0, 548.8, 559.2],
                         [0.0, 548.8, 0.0]], inside), [light_ring], reflectance=CORNELL_WHITE,
                name="ceiling"),
        Polygon(_facing([[549.6, 0.0, 559.2], [0.0, 0.0, 559.2], [0.0, 548.8, 559.2],
                         [556.0, 548.8, 559.2]], inside), reflectance=CORNELL_WHITE,
                name="back_wall"),
        Polygon(_facing([[0.0, 0.0, 559.2], [0.0, 0.0, 0.0], [0.0, 548.8, 0.0],
                         [0.0, 548.8, 559.2]], inside), reflectance=CORNELL_GREEN,
                name="right_wall"),
        Polygon(_facing([[552.8, 0.0, 0.0], [549.6, 0.0, 559.2], [556.0, 548.8, 559.2]], inside),
                reflectance=CORNELL_RED, name="left_wall_a"),
        Polygon(_facing([[552.8, 0.0, 0.0], [556.0, 548.8, 559.2], [556.0, 548.8, 0.0]], inside),
                reflectance=CORNELL_RED, name="left_wall_b"),
        AreaLight(light_ring, emission=light_emission, name="light"),
    ]
    if closed:
        polys.append(Polygon(_facing([[552.8, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 548.8, 0.0],
                                      [556.0, 548.8, 0.0]], inside), reflectance=CORNELL_WHITE,
                             name="front_wall"))
    if blocks:
        for name, top in tops.items():
            h = top[0, 1]
            centre = top.mean(axis=0) - np.array([0.0, 0.5 * h, 0.0])
            polys.append(Polygon(_facing(top, centre, away=True), reflectance=CORNELL_WHITE,
                                 name=f"{name}_top"))
            for k in range(4):
                a, b = top[k], top[(k + 1) % 4]
                side = [a, b, b - [0.0, h, 0.0], a - [0.0, h, 0.0]]
                polys.append(Polygon(_facing(side, centre, away=True), reflectance=CORNELL_WHITE,
                                     name=f"{name}_side{k}"))
    return Scene(polys, name="cornell_box")


def _ceiling_light(room, size, *, emission, drop=0.0):
    cx, cz = 0.5 * room[0], 0.5 * room[2]
    y = room[1] - drop
    ring = _rectangle([cx, y, cz], size[0], size[1], [1, 0, 0], [0, 0, 1])
    return _facing(ring, [cx, 0.0, cz])


def two_rectangles_room(*, emission=10.0, reflectance=0.6):
    """A box room with one rectangular area light and two floating rectangles (Fig. 3.15).

    Room 10 x 10 x 10 (y up); light 2 x 2 in the ceiling; two horizontal
    two-sided rectangles at different heights that cast overlapping
    shadows on the floor.
    """
    room = np.array([10.0, 10.0, 10.0])
    light = _ceiling_light(room, (2.0, 2.0), emission=emission)
    polys = box_room(room, reflectance=reflectance, light=light, name="room")
    polys.append(AreaLight(light, emission=emission, name="light"))
    polys += _two_sided(_rectangle([4.0, 6.0, 4.5], 3.0, 2.0, [1, 0, 0], [0, 0, 1]),
                        reflectance=reflectance, name="rect1")
    polys += _two_sided(_rectangle([6.0, 3.5, 6.0], 2.0, 3.0, [1, 0, 0], [0, 0, 1]),
                        reflectance=reflectance, name="rect2")
    return Scene(polys, name="two_rectangles_room")


def small_shadows_room(*, sizes=(0.4, 0.8, 1.6), height=2.0, light_size=1.0, emission=10.0,
                       reflectance=0.6):
    """A box room with a ceiling light and small floating squares (Fig. 2.8).

    Room 10 x 10 x 10 (y up); a square light of side ``light_size`` in the
    ceiling centre; two-sided horizontal squares of the given sides at
    ``height`` above the floor, along the line z = 5 at x = 2.5, 5, 7.5
    (for three squares).  Their shadows on the floor are about
    ``1.25 * size`` wide (for the default height), so a first mesh coarser
    than that can miss them.
    """
    room = np.array([10.0, 10.0, 10.0])
    light = _ceiling_light(room, (light_size, light_size), emission=emission)
    polys = box_room(room, reflectance=reflectance, light=light, name="room")
    polys.append(AreaLight(light, emission=emission, name="light"))
    xs = np.linspace(2.5, 7.5, len(sizes)) if len(sizes) > 1 else [5.0]
    for k, (x, a) in enumerate(zip(xs, sizes)):
        polys += _two_sided(_rectangle([x, height, 5.0], a, a, [1, 0, 0], [0, 0, 1]),
                            reflectance=reflectance, name=f"square{k}")
    return Scene(polys, name="small_shadows_room")


def small_shadows_depth(mesh, result, *, sizes=(0.4, 0.8, 1.6), height=2.0, light_size=1.0):
    """How dark each square's shadow comes out on the floor of :func:`small_shadows_room` (Fig. 2.8).

    For each square: the darkest floor element within its shadow (the
    square projected from the light's centre, plus a margin), over the mean
    of the open floor around (5, 5); 1 means the mesh shows no shadow.
    ``mesh`` must mesh a :func:`small_shadows_room` built with the same
    ``sizes`` and ``height``; ``result`` is its radiosity solution.

    Returns
    -------
    (len(sizes),) float64
    """
    names = [p.name for p in mesh.scene.polygons]
    if "room_y0" not in names:
        raise ValueError("small_shadows_depth needs a mesh of small_shadows_room (no polygon 'room_y0')")
    light = np.array([5.0, 10.0, 5.0])  # the centre of the ceiling light
    x = mesh.element_centroid
    on = mesh.element_polygon == names.index("room_y0")
    b = result.radiosity.mean(axis=1)
    open_floor = on & (np.hypot(x[:, 0] - 5.0, x[:, 2] - 8.0) < 1.0)
    xs = np.linspace(2.5, 7.5, len(sizes)) if len(sizes) > 1 else [5.0]
    out = []
    for xc, a in zip(xs, sizes):
        c = light + (np.array([xc, height, 5.0]) - light) * light[1] / (light[1] - height)  # on the floor
        near = on & (np.hypot(x[:, 0] - c[0], x[:, 2] - c[2]) < 0.75 * a + 0.3 * light_size)
        out.append(b[near].min() / b[open_floor].mean())
    return np.array(out)


def three_rectangles_box(*, emission=10.0, reflectance=0.6):
    """A box with three floating rectangles (Fig. 4.8).

    Room 10 x 10 x 10 (y up); a 2 x 2 ceiling light; one horizontal, one
    tilted and one vertical two-sided rectangle.
    """
    room = np.array([10.0, 10.0, 10.0])
    light = _ceiling_light(room, (2.0, 2.0), emission=emission)
    polys = box_room(room, reflectance=reflectance, light=light, name="box")
    polys.append(AreaLight(light, emission=emission, name="light"))
    s = np.sqrt(0.5)
    polys += _two_sided(_rectangle([3.5, 6.5, 4.0], 3.0, 2.5, [1, 0, 0], [0, 0, 1]),
                        reflectance=reflectance, name="rect_flat")
    polys += _two_sided(_rectangle([6.5, 4.5, 6.0], 2.5, 2.5, [s, s, 0], [0, 0, 1]),
                        reflectance=reflectance, name="rect_tilted")
    polys += _two_sided(_rectangle([5.0, 2.5, 2.5], 3.0, 2.0, [1, 0, 0], [0, 1, 0]),
                        reflectance=reflectance, name="rect_upright")
    return Scene(polys, name="three_rectangles_box")


def sphere_scene(*, n_lat=12, n_lon=15, emission=2000.0, reflectance=0.6, light_size=0.2):
    """A 180-polygon sphere in a room with a very small area light (Fig. 3.19).

    The sphere (radius 2.5, centre (5, 3, 5) in a 10^3 room) is a
    latitude-longitude polyhedron: ``n_lat * n_lon`` faces (12 * 15 = 180),
    triangles at the poles and planar trapezoids elsewhere.
    """
    room = np.array([10.0, 10.0, 10.0])
    light = _ceiling_light(room, (light_size, light_size), emission=emission)
    polys = box_room(room, reflectance=reflectance, light=light, name="room")
    polys.append(AreaLight(light, emission=emission, name="light"))
    c = np.array([5.0, 3.0, 5.0])
    r = 2.5
    th = np.linspace(0.0, np.pi, n_lat + 1)
    ph = np.linspace(0.0, 2.0 * np.pi, n_lon + 1)

    def pt(i, j):
        return c + r * np.array([np.sin(th[i]) * np.cos(ph[j]), np.cos(th[i]),
                                 np.sin(th[i]) * np.sin(ph[j])])

    for i in range(n_lat):
        for j in range(n_lon):
            if i == 0:
                ring = [pt(0, 0), pt(1, j), pt(1, j + 1)]
            elif i == n_lat - 1:
                ring = [pt(i, j), pt(i, j + 1), pt(n_lat, 0)]
            else:
                ring = [pt(i, j), pt(i, j + 1), pt(i + 1, j + 1), pt(i + 1, j)]
            polys.append(Polygon(_facing(ring, c, away=True), reflectance=reflectance,
                                 name=f"sphere_{i}_{j}"))
    return Scene(polys, name="sphere_scene")


def chair_scene(*, emission=2000.0, reflectance=0.6, light_size=0.2):
    """A chair-like object (seat, four legs, back) under a very small area light (Fig. 3.20)."""
    room = np.array([10.0, 10.0, 10.0])
    light = _ceiling_light(room, (light_size, light_size), emission=emission)
    x0, z0, w, t, hs = 3.5, 3.5, 3.0, 0.3, 2.5
    leg = 0.3
    feet = [(x0, z0), (x0 + w - leg, z0), (x0, z0 + w - leg), (x0 + w - leg, z0 + w - leg)]
    # the legs stand on the floor: it is cut under them (no light reaches there)
    polys = box_room(room, reflectance=reflectance, light=light, name="room",
                     floor_holes=[[[lx, 0.0, lz], [lx + leg, 0.0, lz], [lx + leg, 0.0, lz + leg],
                                   [lx, 0.0, lz + leg]] for lx, lz in feet])
    polys.append(AreaLight(light, emission=emission, name="light"))
    # the seat's sides; its top is cut where the back stands on it and its bottom where the
    # legs meet it (corner squares: the bottom becomes a cross-shaped polygon)
    polys += _solid_box([x0, hs, z0], [x0 + w, hs + t, z0 + w], reflectance=reflectance,
                        name="seat", faces=("x0", "x1", "z0", "z1"))
    centre = np.array([x0 + 0.5 * w, hs + 0.5 * t, z0 + 0.5 * w])
    y = hs + t
    polys.append(Polygon(_facing([[x0, y, z0], [x0 + w, y, z0], [x0 + w, y, z0 + w - t],
                                  [x0, y, z0 + w - t]], centre, away=True),
                         reflectance=reflectance, name="seat_y1"))
    a, b = leg, w - leg
    cross = [(a, 0), (b, 0), (b, a), (w, a), (w, b), (b, b), (b, w), (a, w), (a, b), (0, b),
             (0, a), (a, a)]
    polys.append(Polygon(_facing([[x0 + cx, hs, z0 + cz] for cx, cz in cross], centre,
                                 away=True), reflectance=reflectance, name="seat_y0"))
    for k, (lx, lz) in enumerate(feet):
        polys += _solid_box([lx, 0.0, lz], [lx + leg, hs, lz + leg], reflectance=reflectance,
                            name=f"leg{k}", faces=("x0", "x1", "z0", "z1"))
    polys += _solid_box([x0, hs + t, z0 + w - t], [x0 + w, hs + t + 3.0, z0 + w],
                        reflectance=reflectance, name="back", faces=("x0", "x1", "y1", "z0", "z1"))
    return Scene(polys, name="chair_scene")


def figure_3_4_scene(*, emission=10.0, reflectance=0.6, angle=30.0):
    """A receiver, a square area light and two occluders whose penumbrae overlap (Fig. 3.4).

    The text gives only the counts: the simplified discontinuity edges of
    Fig. 3.4(a) split the receiver into 6 regions by loops and 29 by a BSP
    tree.  Six regions are what two occluders give when their penumbrae
    overlap and their umbrae do not (bright, two penumbra-only, their
    overlap, two umbrae); with a light and occluders in general position
    each casts ``Ns + 2 No`` edges (Fig. 3.3(b)).  So here: a 10 x 10
    floor (y = 0, facing up), a 2 x 2 light at y = 10 facing down, and two
    two-sided 1.6 x 1.6 squares at y = 4, turned by ``angle`` degrees about
    the vertical, 2.4 apart.
    """
    floor = Polygon([[0.0, 0.0, 0.0], [0.0, 0.0, 10.0], [10.0, 0.0, 10.0], [10.0, 0.0, 0.0]],
                    reflectance=reflectance, name="floor")
    light = _ceiling_light(np.array([10.0, 10.0, 10.0]), (2.0, 2.0), emission=emission)
    polys = [floor, AreaLight(light, emission=emission, name="light")]
    a = np.deg2rad(angle)
    rot = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    h = 0.8
    square = np.array([[-h, 0.0, -h], [h, 0.0, -h], [h, 0.0, h], [-h, 0.0, h]]) @ rot.T
    for name, x in (("occluder_a", 3.8), ("occluder_b", 6.2)):
        polys += _two_sided(square + [x, 4.0, 5.0], reflectance=reflectance, name=name)
    return Scene(polys, name="figure_3_4_scene")


CONCAVE_OUTLINES = {
    "L": [[-1.0, -1.0], [1.0, -1.0], [1.0, -0.2], [-0.2, -0.2], [-0.2, 1.0], [-1.0, 1.0]],
    "U": [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [0.4, 1.0], [0.4, -0.3], [-0.4, -0.3], [-0.4, 1.0],
          [-1.0, 1.0]],
    "frame": [[-1.2, -1.2], [1.2, -1.2], [1.2, 1.2], [-1.2, 1.2]],
}
CONCAVE_HOLES = {"frame": [[[-0.3, -0.3], [0.4, -0.3], [0.4, 0.3], [-0.3, 0.3]]]}


def concave_occluder_scene(shape="L", *, light="area", tilt=0.0, height=1.0, light_size=0.5,
                           emission=10.0, reflectance=0.6):
    """One concave occluder over a floor, under one light (concave occluders, exact).

    A 6 x 6 floor (y = 0, facing up, centred on the origin); a two-sided
    occluder ``shape`` ("L": a 2 x 2 square less a 1.2 x 1.2 corner; "U": a
    2 x 2 square less a 0.8 x 1.3 notch; "frame": a 2.4 x 2.4 square with a
    0.7 x 0.6 hole) centred at ``height``, turned by
    ``tilt`` degrees about the x axis out of the floor's plane; a light
    above it, off its centre (at (0.3, 3, 0.2)): ``"area"`` a square of
    side ``light_size`` facing down, ``"point"`` a point light there,
    ``"parallel"`` a parallel light along (0.2, -1, 0.1).
    """
    from polygen.radiosity.scene import ParallelLight, PointLight

    if shape not in CONCAVE_OUTLINES:
        raise ValueError(f"shape: expected one of {sorted(CONCAVE_OUTLINES)}, got {shape!r}")
    floor = Polygon([[-3.0, 0.0, -3.0], [-3.0, 0.0, 3.0], [3.0, 0.0, 3.0], [3.0, 0.0, -3.0]],
                    reflectance=reflectance, name="floor")
    t = np.deg2rad(tilt)
    def lift(ab):
        ab = np.asarray(ab, dtype=np.float64)
        return np.stack([ab[:, 0], height + ab[:, 1] * np.sin(t), ab[:, 1] * np.cos(t)], axis=1)

    occ = Polygon(lift(CONCAVE_OUTLINES[shape]), [lift(h) for h in CONCAVE_HOLES.get(shape, [])],
                  reflectance=reflectance, name=f"{shape}_occluder", two_sided=True)
    polys = [floor, occ]
    centre = np.array([0.3, 3.0, 0.2])
    lights = []
    if light == "area":
        h = 0.5 * light_size
        sq = np.array([[-h, 0.0, -h], [h, 0.0, -h], [h, 0.0, h], [-h, 0.0, h]]) + centre
        polys.append(AreaLight(_facing(sq, centre - [0.0, 1.0, 0.0]), emission=emission, name="light"))
    elif light == "point":
        lights.append(PointLight(centre, emission, name="lamp"))
    elif light == "parallel":
        lights.append(ParallelLight([0.2, -1.0, 0.1], emission, name="sun"))
    else:
        raise ValueError(f'light: expected "area", "point" or "parallel", got {light!r}')
    return Scene(polys, lights, name=f"concave_{shape}_{light}")
