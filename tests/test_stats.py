"""The experiments' statistics: closed forms and known-answer recoveries."""

import numpy as np
import pytest

from itup_jax.errors import InputError
from itup_jax.stats import binned_rate, failure_threshold, paired_ratio, roc_auc, spearman


def test_spearman_is_rank_invariant_and_nan_without_ranking():
    rng = np.random.default_rng(0)
    x = rng.normal(size=50)
    assert spearman(x, np.exp(3 * x)) == pytest.approx(1.0)
    assert spearman(x, -x**3) == pytest.approx(-1.0)
    assert np.isnan(spearman(np.full(50, 2.0), x))  # a constant cost ranks nothing
    assert np.isnan(spearman(x[:2], x[:2]))
    with pytest.raises(InputError, match="spearman"):
        spearman(x, x[:10])


def test_roc_auc_counts_ordered_pairs_and_ties_half():
    # positives {3, 1}, negatives {2, 0, 1}: pairs (pos > neg) 3>2, 3>0, 3>1, 1>0; the tie 1=1 counts half
    assert roc_auc([3, 2, 1, 0, 1], [1, 0, 1, 0, 0]) == pytest.approx(4.5 / 6)
    x = np.random.default_rng(1).normal(size=200)
    assert roc_auc(x, x > 0.3) == 1.0 and roc_auc(-x, x > 0.3) == 0.0  # perfect and reversed orderings
    # two unit-variance Gaussians d apart: AUC = Phi(d / sqrt 2)
    rng = np.random.default_rng(2)
    s = np.r_[rng.normal(1.0, 1.0, 20000), rng.normal(0.0, 1.0, 20000)]
    assert roc_auc(s, np.r_[np.ones(20000), np.zeros(20000)]) == pytest.approx(0.7602, abs=0.01)
    assert np.isnan(roc_auc(x, np.ones(200)))  # one class only: nothing to order
    with pytest.raises(InputError, match="roc_auc"):
        roc_auc(x, x[:10] > 0)


def test_logistic_threshold_recovers_a_known_50_percent_torque():
    rng = np.random.default_rng(1)
    tau = rng.uniform(0.0, 14.0, 4000)
    tau50, slope = 6.9, 1.3
    failed = rng.random(4000) < 1.0 / (1.0 + np.exp(-slope * (tau - tau50)))
    f = failure_threshold(tau, failed, bootstrap=50)
    assert f["tau50"] == pytest.approx(tau50, abs=0.2)
    assert f["slope"] == pytest.approx(slope, rel=0.15)
    lo, hi = f["ci95"]
    assert lo < f["tau50"] < hi and hi - lo < 1.0
    assert f["failures"] == int(failed.sum()) and f["n"] == 4000


def test_logistic_threshold_refuses_what_the_data_does_not_show():
    tau = np.linspace(0, 10, 100)
    assert failure_threshold(tau, np.zeros(100, bool))["tau50"] is None  # nothing failed
    falling = failure_threshold(tau, tau < 5)  # failure falls with torque
    assert falling["tau50"] is None and "slope" in falling["note"]
    rng = np.random.default_rng(2)
    beyond = failure_threshold(tau, rng.random(100) < 0.05 + 0.02 * tau / 10)  # 50 % far beyond 10 N m
    assert beyond["tau50"] is None and "outside" in beyond["note"]
    with pytest.raises(InputError, match="failure_threshold"):
        failure_threshold(tau, np.zeros(5, bool))


def test_binned_rate_counts_and_wilson_interval():
    x = np.arange(100.0)
    flag = x >= 50
    b = binned_rate(x, flag, bins=4)
    assert b["n"] == [25, 25, 25, 25] and b["rate"] == [0.0, 0.0, 1.0, 1.0]
    assert all(lo <= r <= hi for lo, r, hi in zip(b["lo"], b["rate"], b["hi"]))
    # Wilson at p = 0, n = 25: upper bound z^2 / (n + z^2)
    z = 1.959963984540054
    assert b["hi"][0] == pytest.approx(z * z / (25 + z * z))


def test_paired_ratio_closed_form():
    b = np.array([0.1, 0.4, 1.0, 3.0])
    r = paired_ratio(2 * b, b)  # every pair doubles: the ratio is 2 and no resample can move it
    assert r["ratio"] == pytest.approx(2.0) and r["ci95"] == pytest.approx([2.0, 2.0])
    assert (r["lower"], r["higher"], r["n"]) == (0, 4, 4)
    # halves and doubles cancel in the geometric mean; NaN and non-positive pairs are left out
    r = paired_ratio([0.5, 4.0, np.nan, 0.0, 1.0], [1.0, 2.0, 1.0, 1.0, np.inf])
    assert r["ratio"] == pytest.approx(1.0) and (r["lower"], r["higher"], r["n"]) == (1, 1, 2) and r["ci95"] is None
    mixed = paired_ratio(np.array([0.8, 0.9, 1.2, 0.7, 0.6]), np.ones(5), bootstrap=500)
    assert mixed["ratio"] == pytest.approx(np.exp(np.mean(np.log([0.8, 0.9, 1.2, 0.7, 0.6]))))
    assert mixed["ci95"][0] < mixed["ratio"] < mixed["ci95"][1]
    assert paired_ratio([np.nan], [1.0])["ratio"] is None
    with pytest.raises(InputError, match="one length"):
        paired_ratio([1.0, 2.0], [1.0])
