"""Tests for jaxbelt.geometry.path: installed belt path around circles."""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from helpers import assert_trees_close, central_difference
from hypothesis import strategies as st

from jaxbelt.geometry import BeltPath, belt_path, check_belt_path, place_belt, point_on_path, span_midpoints

PI = math.pi

# three-pulley drive plus a back-side idler on the lower span (serpentine), listed CCW
SERP_C = np.array([[0.0, 0.0], [0.2, -0.05], [0.4, 0.0], [0.2, 0.3]])
SERP_R = np.array([0.1, 0.03, 0.05, 0.05])
SERP_W = (1, -1, 1, 1)


def _np(path):
    """Host (numpy) copy of a BeltPath: keeps assertions free of eager jax dispatch."""
    return jax.tree.map(np.asarray, path)


def _bp(c, r, w):
    return _np(belt_path(c, r, w))


def _serp():
    return _bp(SERP_C, SERP_R, SERP_W)


def _segment_samples(p):
    """Arc lengths of the 2k segment starts and of the 2k segment midpoints."""
    seg_len = np.diff(np.append(p.segment_start_s, p.length))
    return p.segment_start_s, p.segment_start_s + 0.5 * seg_len


def _dense_s(p, n=20000):
    """n+1 samples over [0, L] (one shared shape: one compilation of point_on_path)."""
    return np.arange(n + 1) * (float(p.length) / n)


def _winding(points, centre):
    """Winding number of the closed polyline ``points`` around ``centre``."""
    v = np.vstack([points, points[:1]]) - centre
    ang = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    return (ang[-1] - ang[0]) / (2 * PI)


# --------------------------------------------------------------------------- #
# closed-form cases
# --------------------------------------------------------------------------- #
def test_two_equal_circles():
    R, D = 0.1, 0.1 * PI
    raw = belt_path(jnp.array([[0.0, 0.0], [D, 0.0]]), jnp.array([R, R]), (1, 1))
    assert isinstance(raw, BeltPath)
    p = _np(raw)
    np.testing.assert_allclose(p.length, 0.4 * PI, rtol=1e-12)
    np.testing.assert_allclose(p.wrap_angle, [PI, PI], rtol=1e-12)
    np.testing.assert_allclose(p.span_length, [0.1 * PI, 0.1 * PI], rtol=1e-12)
    np.testing.assert_allclose(p.turn, [1, 1])
    assert float(p.orientation) == 1.0
    # CCW loop: lower span runs +x, upper span runs -x
    np.testing.assert_allclose(p.span_start[0], [0.0, -R], atol=1e-15)
    np.testing.assert_allclose(p.span_end[0], [D, -R], atol=1e-15)
    np.testing.assert_allclose(p.span_dir, [[1, 0], [-1, 0]], atol=1e-15)
    # arc-length layout [arc0, span0, arc1, span1], s=0 at the arrival point on pulley 0
    np.testing.assert_allclose(p.segment_start_s, [0, 0.1 * PI, 0.2 * PI, 0.3 * PI], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(p.arrive_angle[0], PI / 2, rtol=1e-12)
    np.testing.assert_allclose(p.arrive_angle[1], -PI / 2, rtol=1e-12)
    np.testing.assert_allclose(p.length, np.sum(p.span_length) + np.sum(p.radii * p.wrap_angle), rtol=1e-14)


def _open_belt_expected(R1, R2, D):
    th1 = PI + 2 * math.asin((R1 - R2) / D)
    th2 = PI - 2 * math.asin((R1 - R2) / D)
    L = 2 * math.sqrt(D**2 - (R1 - R2) ** 2) + R1 * th1 + R2 * th2
    return th1, th2, L


def test_unequal_open_belt_and_clockwise_listing():
    R1, R2, D = 0.15, 0.05, 0.5
    th1, th2, L = _open_belt_expected(R1, R2, D)
    c = np.array([[0.1, -0.2], [0.1 + D * 0.6, -0.2 + D * 0.8]])
    p = _bp(c, np.array([R1, R2]), (1, 1))
    np.testing.assert_allclose(p.wrap_angle, [th1, th2], rtol=1e-12)
    np.testing.assert_allclose(p.length, L, rtol=1e-12)
    np.testing.assert_allclose(p.span_length, [math.sqrt(D**2 - (R1 - R2) ** 2)] * 2, rtol=1e-12)
    # same drive listed the other way round
    q = _bp(c[::-1], np.array([R2, R1]), (1, 1))
    np.testing.assert_allclose(q.length, L, rtol=1e-12)
    np.testing.assert_allclose(q.wrap_angle, [th2, th1], rtol=1e-12)


def test_three_pulleys_clockwise_listing_detected():
    c = np.array([[0.0, 0.0], [0.4, 0.0], [0.2, 0.3]])
    r = np.array([0.1, 0.05, 0.05])
    ccw = _bp(c, r, (1, 1, 1))
    perm = np.array([0, 2, 1])
    cw = _bp(c[perm], r[perm], (1, 1, 1))
    check_belt_path(c, r, (1, 1, 1))
    check_belt_path(c[perm], r[perm], (1, 1, 1))
    assert float(ccw.orientation) == 1.0 and float(cw.orientation) == -1.0
    np.testing.assert_allclose(cw.turn, [-1, -1, -1])
    np.testing.assert_allclose(cw.length, ccw.length, rtol=1e-13)
    np.testing.assert_allclose(cw.wrap_angle, ccw.wrap_angle[perm], rtol=1e-12)
    np.testing.assert_allclose(np.sum(cw.turn * cw.wrap_angle), -2 * PI, rtol=1e-12)


def test_serpentine_clockwise_listing_and_ambiguous_idler():
    p = _serp()
    rev = np.array([0, 3, 2, 1])
    q = _bp(SERP_C[rev], SERP_R[rev], tuple(SERP_W[i] for i in rev))
    assert float(q.orientation) == -1.0
    np.testing.assert_allclose(q.length, p.length, rtol=1e-13)
    np.testing.assert_allclose(q.wrap_angle, p.wrap_angle[rev], rtol=1e-12)
    np.testing.assert_allclose(q.turn, [-1, -1, -1, 1])
    # an idler between two pulleys: only the clockwise reading is a valid belt
    c = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, -0.05]])
    r = np.array([0.1, 0.1, 0.07])
    check_belt_path(c, r, (1, 1, -1))
    a = _bp(c, r, (1, 1, -1))
    assert float(a.orientation) == -1.0
    np.testing.assert_allclose(a.turn, [-1, -1, 1])
    # traced geometry: the decision is taken on the device by the same rule
    t = _np(jax.jit(belt_path, static_argnums=2)(c, r, (1, 1, -1)))
    assert_trees_close(t, a, rtol=1e-13, atol=1e-15, what="traced vs numpy belt path")


# --------------------------------------------------------------------------- #
# serpentine geometry
# --------------------------------------------------------------------------- #
def test_serpentine_turning_tangency_and_sides():
    check_belt_path(SERP_C, SERP_R, SERP_W)
    p = _serp()
    np.testing.assert_allclose(p.turn, [1, -1, 1, 1])
    np.testing.assert_allclose(np.sum(p.turn * p.wrap_angle), 2 * PI, rtol=1e-12)
    assert np.all((np.asarray(p.wrap_angle) > 0) & (np.asarray(p.wrap_angle) < 2 * PI))
    k = 4
    start, end, d = map(np.asarray, (p.span_start, p.span_end, p.span_dir))
    for i in range(k):
        j = (i + 1) % k
        np.testing.assert_allclose(np.linalg.norm(d[i]), 1.0, rtol=1e-14)
        np.testing.assert_allclose(end[i] - start[i], p.span_length[i] * d[i], atol=1e-14)
        for m in (i, j):
            v = SERP_C[m] - start[i]
            dist_line = abs(d[i, 0] * v[1] - d[i, 1] * v[0])
            assert abs(dist_line - SERP_R[m]) < 1e-12
        assert abs(np.linalg.norm(start[i] - SERP_C[i]) - SERP_R[i]) < 1e-12
        assert abs(np.linalg.norm(end[i] - SERP_C[j]) - SERP_R[j]) < 1e-12
    np.testing.assert_allclose(p.length, np.sum(p.span_length) + np.sum(p.radii * p.wrap_angle), rtol=1e-14)
    # inner pulleys inside the loop, the back-side idler outside
    pts = np.asarray(point_on_path(p, _dense_s(p))[0])[:-1]
    for m in range(k):
        wnum = _winding(pts, SERP_C[m])
        assert abs(wnum - (1.0 if SERP_W[m] == 1 else 0.0)) < 1e-9, (m, wnum)


def test_point_on_path_continuity_and_consistency():
    p = _serp()
    L = float(p.length)
    s = _dense_s(p)  # includes s = L (wraps to 0)
    ds = s[1]
    pos, tan, kap = (np.asarray(x) for x in point_on_path(p, s))
    jumps = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    rmin = SERP_R.min()
    assert jumps.max() <= ds * (1 + 1e-9)
    assert jumps.min() >= ds * (1 - ds**2 / (24 * rmin**2) - 1e-9)
    np.testing.assert_allclose(pos[-1], pos[0], atol=1e-13)
    # unit tangents, continuous, consistent with finite differences
    np.testing.assert_allclose(np.linalg.norm(tan, axis=1), 1.0, rtol=1e-13)
    assert np.linalg.norm(np.diff(tan, axis=0), axis=1).max() <= ds / rmin * (1 + 1e-9)
    fd = (pos[2:] - pos[:-2]) / (2 * ds)
    assert np.abs(fd - tan[1:-1]).max() < 2 * ds / rmin
    # curvature: +1/rho (left), -1/rho (right), 0 on spans (checked at segment midpoints)
    sb, mids = _segment_samples(p)
    pb, _, kap_b = (np.asarray(x) for x in point_on_path(p, np.concatenate([sb, mids])))
    exp = np.stack([np.array([1, -1, 1, 1]) / SERP_R, np.zeros(4)], axis=1).reshape(-1)
    np.testing.assert_allclose(kap_b[8:], exp, rtol=1e-13)
    # segment boundaries land on the tangent points
    np.testing.assert_allclose(pb[1:8:2], p.span_start, atol=1e-13)
    np.testing.assert_allclose(pb[0:8:2], np.roll(p.span_end, 1, axis=0), atol=1e-13)
    # periodic, any shape
    s2 = np.linspace(-2 * L, 3 * L, 12).reshape(3, 4)
    a, b, c = point_on_path(p, s2)
    assert a.shape == (3, 4, 2) and b.shape == (3, 4, 2) and c.shape == (3, 4)
    a2, b2, _ = point_on_path(p, s2 + L)
    np.testing.assert_allclose(a2, a, atol=1e-12)
    np.testing.assert_allclose(b2, b, atol=1e-10)


def test_span_midpoints():
    p = _serp()
    mid, d = span_midpoints(p)
    assert mid.shape == (4, 2) and d.shape == (4, 2)
    sb, mids = _segment_samples(p)
    pos, tan, _ = (np.asarray(x) for x in point_on_path(p, np.concatenate([sb, mids])))
    np.testing.assert_allclose(mid, pos[9::2], atol=1e-13)  # midpoints of the spans
    np.testing.assert_allclose(d, tan[9::2], atol=1e-13)


# --------------------------------------------------------------------------- #
# place_belt
# --------------------------------------------------------------------------- #
def test_place_belt():
    p = _serp()
    L = float(p.length)
    n = 80
    L0 = 0.98 * L
    q = np.asarray(place_belt(p, n, L0))
    assert q.shape == (n, 2, 2)
    stretch = L / L0
    np.testing.assert_allclose(np.linalg.norm(q[:, 1], axis=1), stretch, rtol=1e-13)
    h = L / n
    gaps = np.linalg.norm(np.roll(q[:, 0], -1, axis=0) - q[:, 0], axis=1)
    rmin = SERP_R.min()
    assert gaps.max() <= h * (1 + 1e-12)
    assert gaps.min() >= h * (1 - h**2 / (24 * rmin**2)) - 1e-12
    pos, tan, _ = (np.asarray(x)[:-1:250] for x in point_on_path(p, _dense_s(p)))  # s = k h
    np.testing.assert_allclose(q[:, 0], pos, atol=1e-14)
    np.testing.assert_allclose(q[:, 1] / stretch, tan, atol=1e-13)
    # node 0 at the arrival point on pulley 0; s_offset shifts along the path
    np.testing.assert_allclose(q[0, 0], p.span_end[-1], atol=1e-14)
    q1 = np.asarray(place_belt(p, n, L0, s_offset=h))
    np.testing.assert_allclose(q1, np.roll(q, -1, axis=0), atol=1e-12)
    # slope tangent to the path: chord directions between neighbours agree to O(h/rho)
    chord = np.roll(q[:, 0], -1, axis=0) - np.roll(q[:, 0], 1, axis=0)
    chord /= np.linalg.norm(chord, axis=1, keepdims=True)
    assert np.abs(chord - q[:, 1] / stretch).max() < h / rmin


# --------------------------------------------------------------------------- #
# differentiability, jit
# --------------------------------------------------------------------------- #
def test_gradients_under_jit():
    R = 0.1

    def length(D, r):
        c = jnp.stack([jnp.zeros(2), jnp.stack([D, jnp.zeros_like(D)])])
        return belt_path(c, jnp.stack([r, r]), (1, 1)).length

    gD, gR = jax.jit(jax.grad(length, argnums=(0, 1)))(0.1 * PI, R)
    np.testing.assert_allclose(gD, 2.0, atol=1e-10)  # L = 2 D + 2 pi R
    np.testing.assert_allclose(gR, 2 * PI, atol=1e-10)

    # serpentine: forward-mode derivative of the length and of the placed belt (through
    # point_on_path) along a geometry perturbation, vs central differences;
    # wrap_side passed as a static (hashable tuple) argument of an outer jit
    def F(c, r, wrap_side):
        path = belt_path(c, r, wrap_side)
        q = place_belt(path, 15, 0.9)  # no node sits on a segment boundary (kink)
        return jnp.concatenate([path.length[None], q.reshape(-1)])

    rng = np.random.default_rng(0)
    dc, dr = rng.normal(size=SERP_C.shape), rng.normal(size=SERP_R.shape) * 0.1

    @functools.partial(jax.jit, static_argnums=2)
    def jvp_F(c, r, wrap_side):
        return jax.jvp(lambda c_, r_: F(c_, r_, wrap_side), (c, r), (dc, dr))

    val, tang = jvp_F(SERP_C, SERP_R, SERP_W)
    np.testing.assert_allclose(val[0], _serp().length, rtol=1e-14)
    eps = 1e-6
    fd = central_difference(lambda s: F(SERP_C + s * dc, SERP_R + s * dr, SERP_W), 0.0, eps)  # along (dc, dr)
    assert np.all(np.isfinite(tang))
    np.testing.assert_allclose(tang, fd, rtol=1e-6, atol=1e-7)


@settings(max_examples=25, deadline=None)
@given(
    R1=st.floats(0.02, 0.3),
    R2=st.floats(0.02, 0.3),
    gap=st.floats(0.01, 1.0),
    phi=st.floats(-PI, PI),
)
def test_open_belt_formula_random(R1, R2, gap, phi):
    D = R1 + R2 + gap
    th1, th2, L = _open_belt_expected(R1, R2, D)
    c = np.array([[0.3, -0.1], [0.3 + D * math.cos(phi), -0.1 + D * math.sin(phi)]])
    check_belt_path(c, [R1, R2], (1, 1))
    p = _bp(c, np.array([R1, R2]), (1, 1))
    np.testing.assert_allclose(p.length, L, rtol=1e-12)
    np.testing.assert_allclose(p.wrap_angle, [th1, th2], rtol=1e-11)


# --------------------------------------------------------------------------- #
# check_belt_path errors
# --------------------------------------------------------------------------- #
BAD = {
    "single pulley": ([[0, 0]], [0.1], (1,), ["at least 2 pulleys", "[0]"]),
    "zero radius": ([[0, 0], [1, 0]], [0.1, 0.0], (1, 1), ["pulley 1", "> 0"]),
    "negative radius": ([[0, 0], [1, 0]], [0.1, -0.1], (1, 1), ["pulley 1"]),
    "nan radius": ([[0, 0], [1, 0], [0, 1]], [np.nan, 0.1, 0.1], (1, 1, 1), ["pulley 0"]),
    "inf centre": ([[0, 0], [np.inf, 0]], [0.1, 0.1], (1, 1), ["pulley 1", "not finite"]),
    "bad wrap side": ([[0, 0], [1, 0]], [0.1, 0.1], (1, 0), ["pulley(s) [1]"]),
    "shape": ([[0, 0], [1, 0]], [0.1, 0.1, 0.1], (1, 1), ["shape"]),
    "overlap": (
        [[0, 0], [1, 0], [1.15, 0.0], [0.5, 1]],
        [0.1, 0.1, 0.1, 0.1],
        (1, 1, 1, 1),
        ["pulleys 1 and 2", "0.15", "0.2"],
    ),
    "tangent": (
        [[0, 0], [0.2, 0], [0.1, 0.5]],
        [0.1, 0.1, 0.1],
        (1, -1, 1),
        ["pulley 0 to pulley 1", "0.2"],
    ),
    "crossed belt turning": (
        [[0, 0], [1, 0]],
        [0.1, 0.1],
        (1, -1),
        ["pulleys [0, 1]", "2*pi", "wrap side of pulley 1 closes the path with a different drive"],
    ),
    "bow tie order": (
        [[0, 0], [1, 0], [0, 1], [1, 1]],
        [0.1] * 4,
        (1, 1, 1, 1),
        ["pulleys [0, 1, 2, 3]", "4*pi", "list the pulleys in the order [0, 1, 3, 2] (pulley 3 moved"],
    ),
    "cut through pulley": (
        [[0, 0], [1, 0], [0.5, 0.8], [0.5, -0.05]],
        [0.1, 0.1, 0.1, 0.07],
        (1, 1, 1, -1),
        ["span 0 (pulley 0 -> pulley 1) passes through pulley 3", "0.05", "0.07"],
    ),
    "self intersection": (
        [[0, 0], [0.5, 0.3], [1, 0]],
        [0.1, 0.05, 0.1],
        (1, -1, 1),
        [
            "self-intersects",
            "span 0 (pulley 0 -> pulley 1)",
            "span 2 (pulley 2 -> pulley 0)",
            "cannot wrap pulley 1 with its back",
        ],
    ),
}


@pytest.mark.parametrize("name", list(BAD))
def test_check_errors(name):
    c, r, w, parts = BAD[name]
    with pytest.raises(ValueError) as exc:
        check_belt_path(c, r, w)
    msg = str(exc.value)
    for part in parts:
        assert part in msg, (name, part, msg)


def test_check_forced_orientation_hint():
    c, r, w = [[0, 0], [1, 0], [0.5, -0.05]], [0.1, 0.1, 0.07], (1, 1, -1)
    check_belt_path(c, r, w)
    check_belt_path(c, r, w, orientation=-1)
    with pytest.raises(ValueError, match=r"passes through pulley 2.*orientation=-1"):
        check_belt_path(c, r, w, orientation=1)
    with pytest.raises(ValueError, match="orientation"):
        check_belt_path(c, r, w, orientation=0)
    np.testing.assert_allclose(_np(belt_path(c, r, w, orientation=1)).turn, [1, 1, -1])
    np.testing.assert_allclose(_np(belt_path(c, r, w)).turn, [-1, -1, 1])
    with pytest.raises(ValueError, match="orientation"):
        belt_path(c, r, w, orientation=2)


def test_check_accepts_valid_layouts():
    check_belt_path([[0, 0], [0.1 * PI, 0]], [0.1, 0.1], (1, 1))
    check_belt_path(SERP_C, SERP_R, SERP_W)
    check_belt_path(SERP_C[::-1], SERP_R[::-1], SERP_W[::-1])
    check_belt_path(np.array(SERP_C), np.array(SERP_R), np.array(SERP_W))


# --------------------------------------------------------------------------- #
# suggested fixes: applied, they pass and give the drive that was meant
# --------------------------------------------------------------------------- #
def _serpentine_layout(seed: int, k_inner: int, n_back: int):
    """A valid layout: ``k_inner`` pulleys around an ellipse listed counter-clockwise, plus
    ``n_back`` back-side idlers each pressing a different span inward, listed on their span."""
    rng = np.random.default_rng(seed)
    for _ in range(1000):
        r = rng.uniform(0.03, 0.1, k_inner)
        ang = np.sort(rng.uniform(0, 2 * PI, k_inner))
        c = np.stack([rng.uniform(0.15, 0.35) * np.cos(ang), rng.uniform(0.15, 0.35) * np.sin(ang)], 1)
        try:
            check_belt_path(c, r, (1,) * k_inner)
        except ValueError:
            continue
        p = _bp(c, r, (1,) * k_inner)
        if float(p.orientation) != 1 or np.min(p.span_length) < 0.15:
            continue
        C, R, W = list(c), list(r), [1] * k_inner
        for s in sorted(rng.choice(k_inner, n_back, replace=False), reverse=True):
            d = p.span_dir[s]
            rr = rng.uniform(0.025, 0.05)
            inward = np.array([-d[1], d[0]])  # left of the travel direction: into a CCW loop
            ctr = (
                p.span_start[s]
                + d * p.span_length[s] * rng.uniform(0.35, 0.65)
                + inward * (rng.uniform(0.01, 0.03) - rr)
            )
            C.insert(s + 1, ctr), R.insert(s + 1, rr), W.insert(s + 1, -1)
        C, R, W = np.array(C), np.array(R), np.array(W)
        try:
            check_belt_path(C, R, W)
        except ValueError:
            continue
        if np.min(_bp(C, R, tuple(W)).wrap_angle) > np.radians(5):
            return C, R, W
    raise RuntimeError("no layout drawn")


def _same_loop(order, k: int, reverse: bool = False) -> bool:
    target = list(range(k))[::-1] if reverse else list(range(k))
    return any(list(order[i:]) + list(order[:i]) == target for i in range(k))


LAYOUTS = [(0, 4, 1), (1, 5, 1), (2, 4, 2), (5, 5, 2)]  # seed, inner pulleys, back-side idlers


@pytest.mark.parametrize("seed,k_inner,n_back", LAYOUTS)
def test_order_suggestions_restore_the_listed_drive(seed, k_inner, n_back):
    """A pulley listed out of order: every suggested order passes, keeps every pulley on its side
    and gives the intended loop; the only other loop offered is that loop travelled the other way
    (when one pulley is moved among four), and the message says so."""
    C, R, W = _serpentine_layout(seed, k_inner, n_back)
    k = len(R)
    ref = _bp(C, R, tuple(W))
    tried = 0
    for i in range(k):
        for j in range(k):
            user = [m for m in range(k) if m != i]
            user.insert(j, i)
            if _same_loop(user, k):
                continue
            u = np.array(user)
            with pytest.raises(ValueError) as exc:
                check_belt_path(C[u], R[u], W[u])
            orders = [arg for kind, arg in exc.value.suggestions if kind == "order"]
            assert orders, str(exc.value)
            meant = [_same_loop(list(u[o]), k) for o in orders]
            assert any(meant), str(exc.value)
            for o, ok in zip(orders, meant):
                fixed = u[o]  # the suggestion applied: pulley indices of the intended layout
                check_belt_path(C[fixed], R[fixed], W[fixed])
                p = _bp(C[fixed], R[fixed], tuple(W[fixed]))
                np.testing.assert_array_equal(p.wrap_side, W[fixed])  # same pulleys on the same sides
                assert np.all((p.wrap_angle > 0) & (p.wrap_angle < 2 * PI))
                np.testing.assert_allclose(p.length, ref.length, rtol=1e-12)
                np.testing.assert_allclose(p.wrap_angle, ref.wrap_angle[fixed], rtol=1e-9)
                if not ok:  # the intended loop the other way round: only ever offered flagged as such
                    assert k == 4 and _same_loop(list(fixed), k, reverse=True)
                    assert "travelled the other way round" in str(exc.value)
            tried += 1
    assert tried >= k * (k - 3)


@pytest.mark.parametrize("seed,k_inner,n_back", LAYOUTS)
def test_wrap_suggestions_pass_and_say_which_drive(seed, k_inner, n_back):
    """A pulley on the wrong side of the belt: undoing it is among the suggestions; every suggested
    side change passes, moves only that pulley to the stated side and is called a different drive."""
    C, R, W = _serpentine_layout(seed, k_inner, n_back)
    k = len(R)
    refused = 0
    for i in range(k):
        w = W.copy()
        w[i] = -w[i]
        try:
            check_belt_path(C, R, w)
        except ValueError as exc:
            err = exc
        else:
            continue  # the other side makes a valid (different) drive too: nothing to suggest
        refused += 1
        msg = str(err)
        assert ("wrap", i) in err.suggestions, msg
        for kind, m in err.suggestions:
            if kind != "wrap":
                continue
            fixed = w.copy()
            fixed[m] = -fixed[m]
            check_belt_path(C, R, fixed)
            p = _bp(C, R, tuple(fixed))
            np.testing.assert_array_equal(p.wrap_side, fixed)
            assert np.all((p.wrap_angle > 0) & (p.wrap_angle < 2 * PI))
            side = "inner side (wrap_side +1" if fixed[m] > 0 else "back (wrap_side -1"
            assert f"pulley {m} on the belt's {side}" in msg, msg
        assert "different drive" in msg
    assert refused >= 1


def test_back_side_idler_the_belt_cannot_wrap_is_named():
    """A back-side idler above the upper span, where no position in the list lets the belt's back
    reach it: the message says so and offers the inner side only as a different drive (before, it
    just said "flipping the wrap side of pulley 1 gives a consistent path")."""
    c = np.array([[0.0, 0.0], [0.5, 0.3], [1.0, 0.0]])  # the idler stands above the upper span
    r = np.array([0.1, 0.05, 0.1])
    with pytest.raises(ValueError) as exc:
        check_belt_path(c, r, (1, -1, 1))
    msg = str(exc.value)
    assert "the belt cannot wrap pulley 1 with its back (wrap_side -1) at any position" in msg
    assert "pulley 1 on the belt's inner side" in msg and "different drive" in msg
    assert exc.value.suggestions == [("wrap", 1)]
