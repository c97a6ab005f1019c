"""Numba kernels of the volume renderers: pixel bins, the cell walk, samples, fragments, compositing.

Arrays only; the wrappers in :mod:`~polygen.volume.render.raycast` and
:mod:`~polygen.volume.render.shells` validate and allocate. Rays are given
as ``origins (P, 3)`` and unit ``directions (P, 3)``, pixel ``p = row * W + col``.

A cell is bounded by triangles: a tetrahedron by its four faces, a
hexahedron by its six quadrilaterals each cut along the diagonal through
its smallest global node id, so that the two cells sharing a face cut it
the same way (the walk then leaves one cell and enters its neighbour
through the same plane).
"""

import numpy as np

from polygen._jit import njit, prange

EPS_REL = 1e-9


# ------------------------------------------------------------------ projection and bins
@njit
def _project(x, eye, fwd, right, up, half_w, half_h, width, height, ortho):
    """Pixel coordinates ``(col, row)`` of world point ``x``, and its depth along ``fwd``."""
    r0 = x[0] - eye[0]
    r1 = x[1] - eye[1]
    r2 = x[2] - eye[2]
    z = r0 * fwd[0] + r1 * fwd[1] + r2 * fwd[2]
    u = r0 * right[0] + r1 * right[1] + r2 * right[2]
    v = r0 * up[0] + r1 * up[1] + r2 * up[2]
    if not ortho:
        if z <= 0.0:
            return 0.0, 0.0, z
        u /= z
        v /= z
    col = (u / half_w + 1.0) * 0.5 * width - 0.5
    row = (1.0 - v / half_h) * 0.5 * height - 0.5
    return col, row, z


@njit(parallel=True)
def _project_all(pts, eye, fwd, right, up, half_w, half_h, width, height, ortho, out):
    """Pixel coordinates and depth of every point into ``out (N, 3)``: ``(col, row, z)``."""
    for i in prange(pts.shape[0]):
        col, row, z = _project(pts[i], eye, fwd, right, up, half_w, half_h, width, height, ortho)
        out[i, 0] = col
        out[i, 1] = row
        out[i, 2] = z


@njit
def _tri_box(proj, tri, width, height, ortho):
    """Inclusive box ``c0, c1, r0, r1`` of the pixel centres a projected triangle can cover (empty when c0 > c1)."""
    cmin = 1e300
    cmax = -1e300
    rmin = 1e300
    rmax = -1e300
    behind = False
    for k in range(3):
        q = proj[tri[k]]
        if not ortho and q[2] <= 0.0:
            behind = True
        cmin = min(cmin, q[0])
        cmax = max(cmax, q[0])
        rmin = min(rmin, q[1])
        rmax = max(rmax, q[1])
    if behind:  # straddles the eye's plane: any pixel may see it
        return 0, width - 1, 0, height - 1
    # the pixel centres (integer coordinates) inside the box, widened by a hair against round-off
    pad = 1e-6
    c0 = max(0, int(np.ceil(cmin - pad)))
    c1 = min(width - 1, int(np.floor(cmax + pad)))
    r0 = max(0, int(np.ceil(rmin - pad)))
    r1 = min(height - 1, int(np.floor(rmax + pad)))
    return c0, c1, r0, r1


@njit
def bin_triangles(pts, tris, eye, fwd, right, up, half_w, half_h, width, height, ortho):
    """CSR ``(offsets (P+1,), items)`` of the triangles whose pixel box covers each pixel.

    Items of a pixel are in ascending triangle order (the fill runs over the
    triangles in order), which the shell compositing relies on.
    """
    n = tris.shape[0]
    npix = width * height
    proj = np.empty((pts.shape[0], 3))
    _project_all(pts, eye, fwd, right, up, half_w, half_h, width, height, ortho, proj)
    counts = np.zeros(npix + 1, np.int64)
    for i in range(n):
        c0, c1, r0, r1 = _tri_box(proj, tris[i], width, height, ortho)
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                counts[r * width + c + 1] += 1
    for p in range(npix):
        counts[p + 1] += counts[p]
    items = np.empty(counts[npix], np.int64)
    fill = counts[:npix].copy()
    for i in range(n):
        c0, c1, r0, r1 = _tri_box(proj, tris[i], width, height, ortho)
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                p = r * width + c
                items[fill[p]] = i
                fill[p] += 1
    return counts, items


@njit
def _ray_triangle(o, d, a, b, c):
    """Möller-Trumbore: ``(t, u, v, d.n)`` of the ray's hit, t = -1 when it misses (edges inclusive)."""
    e1x = b[0] - a[0]
    e1y = b[1] - a[1]
    e1z = b[2] - a[2]
    e2x = c[0] - a[0]
    e2y = c[1] - a[1]
    e2z = c[2] - a[2]
    px = d[1] * e2z - d[2] * e2y
    py = d[2] * e2x - d[0] * e2z
    pz = d[0] * e2y - d[1] * e2x
    det = e1x * px + e1y * py + e1z * pz
    # d . (e1 x e2) = -det ... sign: det = e1 . (d x e2) = -d . (e1 x e2)
    dn = -det
    if det == 0.0:
        return -1.0, 0.0, 0.0, dn
    inv = 1.0 / det
    tx = o[0] - a[0]
    ty = o[1] - a[1]
    tz = o[2] - a[2]
    u = (tx * px + ty * py + tz * pz) * inv
    tol = 1e-12
    if u < -tol or u > 1.0 + tol:
        return -1.0, 0.0, 0.0, dn
    qx = ty * e1z - tz * e1y
    qy = tz * e1x - tx * e1z
    qz = tx * e1y - ty * e1x
    v = (d[0] * qx + d[1] * qy + d[2] * qz) * inv
    if v < -tol or u + v > 1.0 + tol:
        return -1.0, 0.0, 0.0, dn
    t = (e2x * qx + e2y * qy + e2z * qz) * inv
    return t, u, v, dn


# ------------------------------------------------------------------ cells
@njit
def _face_tri(cells, c, faces, f, j, is_hex, out):
    """Global nodes of triangle ``j`` (0, or 1 for a quad) of local face ``f`` of cell ``c`` into ``out``."""
    if not is_hex:
        out[0] = cells[c, faces[f, 0]]
        out[1] = cells[c, faces[f, 1]]
        out[2] = cells[c, faces[f, 2]]
        return
    k = 0
    best = cells[c, faces[f, 0]]
    for i in range(1, 4):
        g = cells[c, faces[f, i]]
        if g < best:
            best = g
            k = i
    out[0] = cells[c, faces[f, k]]
    if j == 0:
        out[1] = cells[c, faces[f, (k + 1) % 4]]
        out[2] = cells[c, faces[f, (k + 2) % 4]]
    else:
        out[1] = cells[c, faces[f, (k + 2) % 4]]
        out[2] = cells[c, faces[f, (k + 3) % 4]]


@njit
def _cell_exit(pts, cells, faces, is_hex, c, o, d, tri):
    """Where the ray leaves convex cell ``c``: the nearest face plane it goes out through, ``(t, face)``."""
    best = np.inf
    bf = -1
    nsub = 2 if is_hex else 1
    for f in range(faces.shape[0]):
        for j in range(nsub):
            _face_tri(cells, c, faces, f, j, is_hex, tri)
            a = pts[tri[0]]
            b = pts[tri[1]]
            cc = pts[tri[2]]
            e1x = b[0] - a[0]
            e1y = b[1] - a[1]
            e1z = b[2] - a[2]
            e2x = cc[0] - a[0]
            e2y = cc[1] - a[1]
            e2z = cc[2] - a[2]
            nx = e1y * e2z - e1z * e2y
            ny = e1z * e2x - e1x * e2z
            nz = e1x * e2y - e1y * e2x
            dn = d[0] * nx + d[1] * ny + d[2] * nz
            if dn > 0.0:
                t = ((a[0] - o[0]) * nx + (a[1] - o[1]) * ny + (a[2] - o[2]) * nz) / dn
                if t < best:
                    best = t
                    bf = f
    return best, bf


@njit
def _tet_weights(pts, cells, c, x, w):
    """Barycentric weights of ``x`` in tetrahedron ``c`` (Def. 5.5: linear interpolation)."""
    p0 = pts[cells[c, 0]]
    a00 = pts[cells[c, 1], 0] - p0[0]
    a10 = pts[cells[c, 1], 1] - p0[1]
    a20 = pts[cells[c, 1], 2] - p0[2]
    a01 = pts[cells[c, 2], 0] - p0[0]
    a11 = pts[cells[c, 2], 1] - p0[1]
    a21 = pts[cells[c, 2], 2] - p0[2]
    a02 = pts[cells[c, 3], 0] - p0[0]
    a12 = pts[cells[c, 3], 1] - p0[1]
    a22 = pts[cells[c, 3], 2] - p0[2]
    b0 = x[0] - p0[0]
    b1 = x[1] - p0[1]
    b2 = x[2] - p0[2]
    det = (a00 * (a11 * a22 - a12 * a21) - a01 * (a10 * a22 - a12 * a20) + a02 * (a10 * a21 - a11 * a20))
    l1 = (b0 * (a11 * a22 - a12 * a21) - a01 * (b1 * a22 - a12 * b2) + a02 * (b1 * a21 - a11 * b2)) / det
    l2 = (a00 * (b1 * a22 - a12 * b2) - b0 * (a10 * a22 - a12 * a20) + a02 * (a10 * b2 - b1 * a20)) / det
    l3 = (a00 * (a11 * b2 - b1 * a21) - a01 * (a10 * b2 - b1 * a20) + b0 * (a10 * a21 - a11 * a20)) / det
    w[0] = 1.0 - l1 - l2 - l3
    w[1] = l1
    w[2] = l2
    w[3] = l3


@njit
def _hex_shape(r, s, t, n, dn):
    """Trilinear shape functions ``n (8,)`` and their derivatives ``dn (8, 3)`` at (r, s, t) in [0, 1]^3."""
    rr = (1.0 - r, r)
    ss = (1.0 - s, s)
    tt = (1.0 - t, t)
    # VTK hexahedron corner order: (0,0,0) (1,0,0) (1,1,0) (0,1,0) then z = 1
    ir = (0, 1, 1, 0, 0, 1, 1, 0)
    js = (0, 0, 1, 1, 0, 0, 1, 1)
    kt = (0, 0, 0, 0, 1, 1, 1, 1)
    for i in range(8):
        a = rr[ir[i]]
        b = ss[js[i]]
        c = tt[kt[i]]
        n[i] = a * b * c
        sa = 1.0 if ir[i] == 1 else -1.0
        sb = 1.0 if js[i] == 1 else -1.0
        sc = 1.0 if kt[i] == 1 else -1.0
        dn[i, 0] = sa * b * c
        dn[i, 1] = a * sb * c
        dn[i, 2] = a * b * sc


@njit
def _hex_weights(pts, cells, c, x, w, rst, dn):
    """Trilinear weights of ``x`` in hexahedron ``c`` by Newton's method from ``rst`` (updated in place)."""
    for _ in range(12):
        _hex_shape(rst[0], rst[1], rst[2], w, dn)
        f0 = -x[0]
        f1 = -x[1]
        f2 = -x[2]
        j00 = j01 = j02 = j10 = j11 = j12 = j20 = j21 = j22 = 0.0
        for i in range(8):
            p = pts[cells[c, i]]
            f0 += w[i] * p[0]
            f1 += w[i] * p[1]
            f2 += w[i] * p[2]
            j00 += dn[i, 0] * p[0]
            j01 += dn[i, 1] * p[0]
            j02 += dn[i, 2] * p[0]
            j10 += dn[i, 0] * p[1]
            j11 += dn[i, 1] * p[1]
            j12 += dn[i, 2] * p[1]
            j20 += dn[i, 0] * p[2]
            j21 += dn[i, 1] * p[2]
            j22 += dn[i, 2] * p[2]
        det = j00 * (j11 * j22 - j12 * j21) - j01 * (j10 * j22 - j12 * j20) + j02 * (j10 * j21 - j11 * j20)
        if det == 0.0:
            break
        d0 = (f0 * (j11 * j22 - j12 * j21) - j01 * (f1 * j22 - j12 * f2) + j02 * (f1 * j21 - j11 * f2)) / det
        d1 = (j00 * (f1 * j22 - j12 * f2) - f0 * (j10 * j22 - j12 * j20) + j02 * (j10 * f2 - f1 * j20)) / det
        d2 = (j00 * (j11 * f2 - f1 * j21) - j01 * (j10 * f2 - f1 * j20) + f0 * (j10 * j21 - j11 * j20)) / det
        rst[0] -= d0
        rst[1] -= d1
        rst[2] -= d2
        if abs(d0) + abs(d1) + abs(d2) < 1e-12:
            break
    _hex_shape(rst[0], rst[1], rst[2], w, dn)


# ------------------------------------------------------------------ transfer function and shading
@njit
def _lut(xs, ys, x):
    """Piecewise-linear table ``ys`` over ascending knots ``xs`` at ``x``, clamped at the ends."""
    n = xs.shape[0]
    if x <= xs[0]:
        return 0
    if x >= xs[n - 1]:
        return n - 1
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@njit
def _classify(knots, rgb, alpha, tau, s, gx, gy, gz, lx, ly, lz, emission, energy, shade, out):
    """Colour ``c`` (7.2) into ``out[:3]`` and opacity ``a`` into ``out[3]`` of one sample.

    ``tau == 0``: ``alpha`` holds each knot's opacity already corrected for
    the sample spacing, interpolated as it is. ``tau > 0`` (the attenuation
    model): ``alpha`` holds the table's opacities, read as attenuation
    coefficients per unit length, and the sample's opacity is
    ``1 - exp(-alpha(s) * tau)``, ``tau = step / unit``.
    """
    n = knots.shape[0]
    i = _lut(knots, alpha, s)
    if s <= knots[0] or s >= knots[n - 1] or n == 1:
        f = 0.0
    else:
        f = (s - knots[i]) / (knots[i + 1] - knots[i])
    j = i + 1 if i + 1 < n else i
    a = alpha[i] + f * (alpha[j] - alpha[i])
    if tau > 0.0:
        a = 1.0 - np.exp(-a * tau)
    out[3] = a
    if shade:
        g = np.sqrt(gx * gx + gy * gy + gz * gz)
        gl = 0.0
        if g > 0.0:
            # two-sided: the gradient's sign says nothing about which side faces the light
            gl = abs(gx * lx + gy * ly + gz * lz) / g
        for ch in range(3):
            r = rgb[i, ch] + f * (rgb[j, ch] - rgb[i, ch])
            out[ch] = emission[ch] + gl * energy * r  # (7.2) c = E + (G.L) l r
    else:
        for ch in range(3):
            out[ch] = rgb[i, ch] + f * (rgb[j, ch] - rgb[i, ch])


# ------------------------------------------------------------------ ray casting
@njit
def _next_entry(pts, btris, bcell, items, lo, hi, o, d, t_min, tri):
    """The nearest boundary triangle the ray enters the volume through at ``t >= t_min``: ``(t, cell)``."""
    best = np.inf
    bc = -1
    for q in range(lo, hi):
        i = items[q]
        t, u, v, dn = _ray_triangle(o, d, pts[btris[i, 0]], pts[btris[i, 1]], pts[btris[i, 2]])
        if dn < 0.0 and t >= t_min and t < best:
            best = t
            bc = bcell[i]
    return best, bc


@njit(parallel=True)
def sample_bounds(pts, btris, offsets, items, origins, dirs, start_cell, step, cap):
    """An upper bound ``cap[p]`` on the samples of pixel ``p``'s ray, without walking cells.

    The samples ``k * step`` lie between the nearest and the farthest
    boundary crossing of the ray (from the eye when it starts inside), so
    ``floor(t_far / step) - ceil(t_near / step) + 1`` plus two for round-off
    bounds them; a ray through holes gets more room than it uses.
    """
    npix = origins.shape[0]
    for p in prange(npix):
        o = origins[p]
        d = dirs[p]
        t_near = 0.0 if start_cell[p] >= 0 else np.inf
        t_far = -np.inf
        for q in range(offsets[p], offsets[p + 1]):
            i = items[q]
            t, u, v, dn = _ray_triangle(o, d, pts[btris[i, 0]], pts[btris[i, 1]], pts[btris[i, 2]])
            if t >= 0.0:
                t_near = min(t_near, t)
                t_far = max(t_far, t)
        if t_far < t_near:
            cap[p] = 0
        else:
            cap[p] = int(np.floor(t_far / step)) - int(np.ceil(t_near / step)) + 3


@njit(parallel=True)
def cast(pts, cells, faces, is_hex, nb, values, grads, btris, bcell, offsets, items, origins, dirs, start_cell,
         step, knots, rgb, alpha, tau, emission, energy, light, headlight, shade, background, scale, max_steps,
         store_off, store, image, length, entries, samples):
    """Ray casting (7.8.1): walk every pixel's ray cell to cell and composite its samples.

    With ``store_off (P+1,)`` non-empty, each sample's ``(S, Gx, Gy, Gz)``
    also goes to row ``store_off[p] + k`` of ``store`` (``k`` counted from
    the eye), so that :func:`composite_samples` can classify them again
    without walking; a pixel with more samples than its room stores none
    beyond it, and ``samples[p]`` then exceeds the room (the wrapper checks).

    Samples lie at ``t = k * step`` (``k >= 0``) along the unit ray, the
    distance from the eye (the equi-distance surfaces of (7.3) cross the
    ray there too). Compositing runs front to back,
    ``C += T a c; T *= 1 - a``, which is (7.1), ``C_t = C_{t-1}(1 - a) + c a``
    from the far end, unrolled: both give ``sum_t c_t a_t prod_{s nearer} (1 - a_s)``.
    ``length`` gets the length of the ray inside material, ``entries`` the
    segments walked (one per entry through the boundary), ``samples`` the samples.
    """
    npix = origins.shape[0]
    nn = cells.shape[1]
    eps = EPS_REL * scale
    keep = store_off.shape[0] > 0
    for p in prange(npix):
        o = origins[p]
        d = dirs[p]
        room = store_off[p + 1] - store_off[p] if keep else 0
        tri = np.empty(3, np.int64)
        w = np.empty(8)
        dnd = np.empty((8, 3))
        rst = np.empty(3)
        x = np.empty(3)
        cl = np.empty(4)
        if headlight:
            lx, ly, lz = -d[0], -d[1], -d[2]
        else:
            lx, ly, lz = light[0], light[1], light[2]
        c_r = 0.0
        c_g = 0.0
        c_b = 0.0
        trans = 1.0
        total = 0.0
        n_seg = 0
        n_smp = 0
        k_next = 0
        t = 0.0
        c = start_cell[p]
        lo = offsets[p]
        hi = offsets[p + 1]
        if c < 0:
            t, c = _next_entry(pts, btris, bcell, items, lo, hi, o, d, 0.0, tri)
        while c >= 0:
            n_seg += 1
            steps = 0
            while c >= 0:
                t_out, f = _cell_exit(pts, cells, faces, is_hex, c, o, d, tri)
                if t_out < t:
                    t_out = t  # the ray only grazes this cell (round-off at an edge): go on
                k = max(k_next, int(np.ceil(t / step)))
                rst[0] = 0.5
                rst[1] = 0.5
                rst[2] = 0.5
                while k * step < t_out:
                    ts = k * step
                    x[0] = o[0] + ts * d[0]
                    x[1] = o[1] + ts * d[1]
                    x[2] = o[2] + ts * d[2]
                    if is_hex:
                        _hex_weights(pts, cells, c, x, w, rst, dnd)
                    else:
                        _tet_weights(pts, cells, c, x, w)
                    s = 0.0
                    gx = 0.0
                    gy = 0.0
                    gz = 0.0
                    for i in range(nn):
                        g = cells[c, i]
                        s += w[i] * values[g]
                        gx += w[i] * grads[g, 0]
                        gy += w[i] * grads[g, 1]
                        gz += w[i] * grads[g, 2]
                    if keep and n_smp < room:
                        row = store_off[p] + n_smp
                        store[row, 0] = s
                        store[row, 1] = gx
                        store[row, 2] = gy
                        store[row, 3] = gz
                    _classify(knots, rgb, alpha, tau, s, gx, gy, gz, lx, ly, lz, emission, energy, shade, cl)
                    a = cl[3]
                    c_r += trans * a * cl[0]
                    c_g += trans * a * cl[1]
                    c_b += trans * a * cl[2]
                    trans *= 1.0 - a
                    n_smp += 1
                    k += 1
                k_next = k
                total += t_out - t
                t = t_out
                if f < 0:
                    break
                c = nb[c, f]
                steps += 1
                if steps > max_steps:
                    break
            t, c = _next_entry(pts, btris, bcell, items, lo, hi, o, d, t - eps, tri)
        image[p, 0] = c_r + trans * background[0]
        image[p, 1] = c_g + trans * background[1]
        image[p, 2] = c_b + trans * background[2]
        length[p] = total
        entries[p] = n_seg
        samples[p] = n_smp


@njit(parallel=True)
def composite_samples(store_off, samples, store, dirs, knots, rgb, alpha, tau, emission, energy, light, headlight,
                      shade, background, image):
    """(7.1) front to back over the kept samples of each pixel, as :func:`cast` composites them.

    Same arithmetic in the same order, so the image equals the walk's bit for bit.
    """
    npix = dirs.shape[0]
    for p in prange(npix):
        cl = np.empty(4)
        d = dirs[p]
        if headlight:
            lx, ly, lz = -d[0], -d[1], -d[2]
        else:
            lx, ly, lz = light[0], light[1], light[2]
        c_r = 0.0
        c_g = 0.0
        c_b = 0.0
        trans = 1.0
        start = store_off[p]
        for q in range(start, start + samples[p]):
            _classify(knots, rgb, alpha, tau, store[q, 0], store[q, 1], store[q, 2], store[q, 3], lx, ly, lz,
                      emission, energy, shade, cl)
            a = cl[3]
            c_r += trans * a * cl[0]
            c_g += trans * a * cl[1]
            c_b += trans * a * cl[2]
            trans *= 1.0 - a
        image[p, 0] = c_r + trans * background[0]
        image[p, 1] = c_g + trans * background[1]
        image[p, 2] = c_b + trans * background[2]


# ------------------------------------------------------------------ equi-distance surfaces
@njit(parallel=True)
def fill_fragments(pts, tris, tri_shell, vs, vg, offsets, items, origins, dirs, frag_sg, frag_n):
    """The fragments of each pixel, nearest shell first: S and gradient at the hit.

    Pixel ``p``'s fragments go to rows ``offsets[p]:offsets[p] + frag_n[p]``
    (a pixel has at most as many as triangles binned to it).

    A ray crosses an equi-distance surface once, so a second hit on the same
    shell (the ray through an edge two triangles share) is dropped: ``frag_n``
    counts the ones kept. Items arrive in ascending triangle order, and the
    triangles are stored shell by shell, so the fragments come out sorted.
    """
    npix = origins.shape[0]
    for p in prange(npix):
        o = origins[p]
        d = dirs[p]
        n = offsets[p]
        last = -1
        for q in range(offsets[p], offsets[p + 1]):
            i = items[q]
            a = tris[i, 0]
            b = tris[i, 1]
            c = tris[i, 2]
            t, u, v, dn = _ray_triangle(o, d, pts[a], pts[b], pts[c])
            if t > 0.0 and tri_shell[i] != last:
                last = tri_shell[i]
                w0 = 1.0 - u - v
                frag_sg[n, 0] = w0 * vs[a] + u * vs[b] + v * vs[c]
                for ch in range(3):
                    frag_sg[n, 1 + ch] = w0 * vg[a, ch] + u * vg[b, ch] + v * vg[c, ch]
                n += 1
        frag_n[p] = n - offsets[p]


@njit(parallel=True)
def composite_fragments(frag_off, frag_n, frag_sg, dirs, knots, rgb, alpha, tau, emission, energy, light, headlight,
                        shade, background, image):
    """(7.1) back to front over each pixel's fragments: ``C_t = C_{t-1}(1 - a) + c a``, ``C_0`` the background."""
    npix = frag_off.shape[0] - 1
    for p in prange(npix):
        cl = np.empty(4)
        d = dirs[p]
        if headlight:
            lx, ly, lz = -d[0], -d[1], -d[2]
        else:
            lx, ly, lz = light[0], light[1], light[2]
        c_r = background[0]
        c_g = background[1]
        c_b = background[2]
        start = frag_off[p]
        for q in range(start + frag_n[p] - 1, start - 1, -1):  # far to near
            _classify(knots, rgb, alpha, tau, frag_sg[q, 0], frag_sg[q, 1], frag_sg[q, 2], frag_sg[q, 3], lx, ly, lz,
                      emission, energy, shade, cl)
            a = cl[3]
            c_r = c_r * (1.0 - a) + cl[0] * a
            c_g = c_g * (1.0 - a) + cl[1] * a
            c_b = c_b * (1.0 - a) + cl[2] * a
        image[p, 0] = c_r
        image[p, 1] = c_g
        image[p, 2] = c_b
