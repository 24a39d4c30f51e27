"""Shape buckets (shapes.py): the padding bounds the compiles and changes no result, bit for bit."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax
from itup_jax import grasp_sampler
from itup_jax.errors import InputError
from itup_jax.rotations import quat_to_matrix
from itup_jax.sdgnet import features
from itup_jax.shapes import bucket, pad_rows_repeating, pad_zeros_high
from itup_jax.wrench import task_loads

NO_BUCKETS = 64  # bits: bucket(n) == n for every n < 2**64, i.e. the unpadded sizes


@pytest.mark.parametrize("bits", [1, 3, 4])
def test_bucket_bounds_and_counts(bits):
    ns = np.arange(1, 20000)
    b = np.array([bucket(int(n), bits) for n in ns])
    assert (b >= ns).all() and (b <= ns * (1 + 2.0 ** (1 - bits))).all()
    assert (np.diff(b) >= 0).all()  # monotone
    assert all(bucket(int(v), bits) == v for v in np.unique(b))  # a bucket is its own bucket
    assert all(bin(int(v)).rstrip("0").count("1") <= bits for v in b)  # at most `bits` significant digits
    for lo in (1024, 2048, 4096):  # 2**(bits - 1) buckets per octave
        assert len(np.unique(b[(ns > lo) & (ns <= 2 * lo)])) == 2 ** (bits - 1)
    assert bucket(0, bits) == 0


@pytest.mark.parametrize("n, bits", [(-1, 3), (2.5, 3), (True, 3), (10, 0)])
def test_bucket_refuses_bad_input(n, bits):
    with pytest.raises(InputError, match="bucket"):
        bucket(n, bits)


def test_padding_helpers():
    a = np.arange(30.0).reshape(10, 3)
    p = pad_rows_repeating(a, 2)  # 10 -> 12
    assert p.shape == (12, 3) and (p[:10] == a).all() and (p[10:] == a[0]).all()
    assert pad_rows_repeating(a[:8], 2).shape == (8, 3)  # 8 is a bucket of 2 bits already
    with pytest.raises(InputError, match="at least one row"):
        pad_rows_repeating(np.zeros((0, 3)), 2)
    z = pad_zeros_high(np.ones((5, 9, 3)), 2)  # 5 -> 6, 9 -> 12, 3 -> 3
    assert z.shape == (6, 12, 3) and z[:5, :9].sum() == 5 * 9 * 3 and z.sum() == 5 * 9 * 3


def test_sampler_padding_changes_no_grasp(tools, monkeypatch):
    """Flat- and point-contact grasps from padded points equal those from the unpadded ones, bit for bit."""
    tool = tools["hammer"]
    s = len(grasp_sampler.collision_points(tool, grasp_sampler.SamplerConfig().surface_spacing))
    assert bucket(s, grasp_sampler.POINT_BUCKET_BITS) > s  # the test pads something
    cfgs = [grasp_sampler.SamplerConfig(contact=c) for c in grasp_sampler.CONTACT_MODELS]
    padded = [itup_jax.sample_grasps(tool, 48, seed=5, config=c) for c in cfgs]
    monkeypatch.setattr(grasp_sampler, "POINT_BUCKET_BITS", NO_BUCKETS)
    plain = [itup_jax.sample_grasps(tool, 48, seed=5, config=c) for c in cfgs]
    for a, b in zip(padded, plain):
        for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_point_padding_is_invisible_to_the_kernels(rng, monkeypatch):
    """The kernels see the padded points as the unpadded ones, also where a wrong pad point would show: a
    grasp at the origin whose footprint holds no tool point (a zero pad point would lie inside it)."""
    pts = rng.normal(size=(1001, 3)) * 0.003 + 0.1  # 1001 points -> a bucket of 1024; all far from the origin
    assert bucket(len(pts), grasp_sampler.POINT_BUCKET_BITS) > len(pts)
    R = np.broadcast_to(np.eye(3), (40, 3, 3))
    p = np.concatenate([np.zeros((1, 3)), 0.1 + rng.normal(size=(39, 3)) * 0.01])
    opening = np.full(40, 0.02)
    padded = grasp_sampler.pad_span(pts, R, p), grasp_sampler.gripper_collides(pts, R, p, opening)
    monkeypatch.setattr(grasp_sampler, "POINT_BUCKET_BITS", NO_BUCKETS)
    plain = grasp_sampler.pad_span(pts, R, p), grasp_sampler.gripper_collides(pts, R, p, opening)
    assert np.isposinf(plain[0][0, 0]) and np.isneginf(plain[0][0, 1])  # the premise: nothing in its footprint
    assert np.isfinite(plain[0][1:]).any() and plain[1].any() and not plain[1].all()  # and the rest is not trivial
    for a, b in zip(padded, plain):
        np.testing.assert_array_equal(a, b)


def test_sampler_kernels_compile_once_per_bucket(rng):
    """Two point counts in one bucket (4549 and 4600 -> 4608) share one executable of each kernel."""
    R = np.broadcast_to(np.eye(3), (5, 3, 3))
    p = rng.normal(scale=0.01, size=(5, 3))
    before = (grasp_sampler.pad_span_batch._cache_size(), grasp_sampler.gripper_hits_batch._cache_size())
    for s in (4549, 4600):
        pts = rng.normal(scale=0.02, size=(s, 3))
        grasp_sampler.pad_span(pts, R, p)
        grasp_sampler.gripper_collides(pts, R, p, np.full(5, 0.03))
    after = (grasp_sampler.pad_span_batch._cache_size(), grasp_sampler.gripper_hits_batch._cache_size())
    assert after[0] - before[0] <= 1 and after[1] - before[1] <= 1


@pytest.mark.slow
def test_field_padding_changes_no_feature(tasks, monkeypatch):
    """The features from the zero-padded density field equal those from the unpadded one, bit for bit,
    and two fields in one size bucket share one compile of the batched features."""
    tool, task = tasks["hammer"]
    spec = features.FeatureSpec(num_points=256)
    grasps = itup_jax.sample_grasps(tool, 16, seed=2)
    loads = task_loads(tool.params, task)
    bits = features.FIELD_BUCKET_BITS
    padded = features.tool_field(tool, spec)
    monkeypatch.setattr(features, "FIELD_BUCKET_BITS", NO_BUCKETS)
    plain = features.tool_field(tool, spec)
    assert padded.values.shape != plain.values.shape  # the test pads something
    assert (np.asarray(padded.values)[tuple(slice(0, n) for n in plain.values.shape)] == np.asarray(plain.values)).all()
    f_pad = np.asarray(features.batched_features(padded, loads, tool.params, grasps, spec=spec))
    f_plain = np.asarray(features.batched_features(plain, loads, tool.params, grasps, spec=spec))
    np.testing.assert_array_equal(f_pad, f_plain)
    # reads that straddle the unpadded grid's high corner, where the padding lies: zeros as map_coordinates'
    # cval gives beyond the grid (the grasps above read the tool's middle, far from any edge)
    corner = plain.origin + plain.spacing * (np.array(plain.values.shape) - 1)
    for R in (np.eye(3), quat_to_matrix(jnp.array([0.9, 0.1, -0.3, 0.2]) / np.sqrt(0.95))):
        occ = [np.asarray(features.occupancy(f, corner, jnp.asarray(R), spec)) for f in (padded, plain)]
        np.testing.assert_array_equal(occ[0], occ[1])
    # a second field in padded's bucket (the same values, cut by one voxel per axis, padded again)
    before = features.batched_features._cache_size()
    cut = features.DensityField(values=jnp.asarray(pad_zeros_high(np.asarray(plain.values)[:-1, :-1, :-1], bits)),
                                origin=plain.origin, spacing=plain.spacing)
    assert cut.values.shape == padded.values.shape
    features.batched_features(cut, loads, tool.params, grasps, spec=spec)
    assert features.batched_features._cache_size() == before


def test_to_device_is_jnp_asarray_without_a_compile():
    from itup_jax.shapes import to_device

    rng = np.random.default_rng(0)
    for a, dt in [(rng.random((5, 3)), None), (rng.random((4, 2)).astype(np.float32), None), (1.2345678901, float),
                  ([1, 2, 3], None), (np.arange(4), None), (np.array([True, False]), None), (rng.random(3), jnp.float32),
                  (-0.0, float)]:
        want, got = jnp.asarray(a, dt), to_device(a, dt)
        assert got.dtype == want.dtype and got.shape == want.shape
        assert np.asarray(got).tobytes() == np.asarray(want).tobytes()  # bit for bit, the sign of zero too
    host = np.ones(3, np.float32)
    on_device = to_device(host)
    host[0] = 5.0  # a copy: the host array's later changes do not reach it
    assert np.asarray(on_device).tolist() == [1.0, 1.0, 1.0]
    traced = jax.jit(lambda x: to_device(x, jnp.float32) * 2)(jnp.ones(2))  # a tracer passes through
    assert np.asarray(traced).tolist() == [2.0, 2.0]


def test_candidate_padding_bounds_the_compiles_and_changes_no_result():
    """21-24 candidates share the bucket 24: one executable of the wrench costs for all four counts, and
    every count's costs, SDG-Net scores and guard distances are the first rows of the 24's, bit for bit
    (each candidate's result is its own row; the padding repeats the first candidate)."""
    from itup_jax import costs, ood
    from itup_jax.shapes import CANDIDATE_BUCKET_BITS, pad_batch, unpad_batch

    assert bucket(21, CANDIDATE_BUCKET_BITS) == 24
    tool = itup_jax.load_tool("hammer")
    task = itup_jax.make_task("hammer", tool)
    g = itup_jax.sample_grasps(tool, 24, seed=0)
    full_c, full_s, full_g = itup_jax.wrench_costs(tool, task, g), itup_jax.score(tool, task, g), ood.check(tool, task, g)
    before = costs.wrench_costs_jit._cache_size()
    for n in (21, 22, 23):
        c, s, r = itup_jax.wrench_costs(tool, task, g[:n]), itup_jax.score(tool, task, g[:n]), ood.check(tool, task, g[:n])
        assert len(c.tau) == len(s.total) == len(r.per_candidate) == n and isinstance(s.total, jax.Array)
        for got, want in ((c.tau, full_c.tau), (c.total, full_c.total), (s.total, full_s.total), (s.p_failed, full_s.p_failed),
                          (r.per_candidate, full_g.per_candidate)):
            np.testing.assert_array_equal(np.asarray(got), np.asarray(want)[:n])
    assert costs.wrench_costs_jit._cache_size() == before
    padded, n = pad_batch(g[:21])
    assert n == 21 and len(padded) == 24 and np.array_equal(np.asarray(padded.width)[21:], np.repeat(np.asarray(g.width)[:1], 3))
    assert pad_batch(g)[0] is g and unpad_batch(g, 24) is not None  # a bucket's count stays as it is
