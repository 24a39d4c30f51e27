"""Statistics the experiments share (host-side NumPy/SciPy; nothing here is differentiated).

    spearman(a, b)                        rank correlation, NaN when either side has no ranking
    roc_auc(score, label)                 P(a positive's score > a negative's), ties count half
    failure_threshold(torque, failed)     logistic fit of P(fail | peak torque); the 50 % torque
    binned_rate(x, flag, bins)            empirical rate per equal-count bin with Wilson intervals

SciPy is imported inside the functions that need it: `scipy.stats` alone costs ~0.5 s of a command's
start on a 2-core CPU, and `itup plan`/`itup demo` import this module without calling them.
"""

from __future__ import annotations

import numpy as np

from itup_jax.errors import InputError, is_integer


def spearman(a, b) -> float:
    """Spearman rank correlation of two [N] samples; NaN when N < 3 or either side is constant
    (a cost that gives every candidate the same value does not rank them)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape or a.ndim != 1:
        raise InputError(f"spearman: need two [N] arrays of one length, got {a.shape} and {b.shape}")
    if len(a) < 3 or np.ptp(a) <= 1e-12 * max(1.0, np.abs(a).max()) or np.ptp(b) <= 1e-12 * max(1.0, np.abs(b).max()):
        return float("nan")
    from scipy.stats import spearmanr

    return float(spearmanr(a, b).statistic)


def roc_auc(score, label) -> float:
    """Area under the ROC curve of `score` [N] for the boolean `label` [N]: the probability that a random
    positive scores above a random negative, ties counting half (the Mann-Whitney U statistic over
    n_pos x n_neg). NaN when either class is empty (no pair to order)."""
    score, label = np.asarray(score, float), np.asarray(label)
    if score.shape != label.shape or score.ndim != 1:
        raise InputError(f"roc_auc: need [N] scores and [N] labels, got {score.shape} and {label.shape}")
    label = label.astype(bool)
    pos, neg = score[label], score[~label]
    if len(pos) == 0 or len(neg) == 0:
        return float("nan")
    from scipy.stats import mannwhitneyu

    return float(mannwhitneyu(pos, neg).statistic / (len(pos) * len(neg)))


def _logistic_mle(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(a, b) maximising sum log sigma(+-(a + b x)) on standardised x (BFGS, analytic gradient)."""
    from scipy.optimize import minimize
    from scipy.special import expit, log_expit

    mu, sd = x.mean(), x.std() or 1.0
    z = (x - mu) / sd
    s = 2.0 * y - 1.0

    def nll(th):
        t = s * (th[0] + th[1] * z)
        w = expit(-t) * s  # d(-log sigma(t))/d(a + b z) = -sigma(-t) s
        return -log_expit(t).sum(), np.array([-w.sum(), -(w * z).sum()])

    th = minimize(nll, np.zeros(2), jac=True, method="BFGS").x
    return np.array([th[0] - th[1] * mu / sd, th[1] / sd])


def failure_threshold(torque, failed, *, bootstrap: int = 200, seed: int = 0) -> dict:
    """Logistic model P(failed | tau) = sigma(a + b tau) fitted by maximum likelihood.

    torque: [N] peak torque (N m); failed: [N] bool. Returns {"tau50": -a/b (N m, the torque at which
    failure is as likely as not), "slope": b (1/(N m)), "a", "ci95": [lo, hi] of tau50 from a
    percentile bootstrap over rollouts, "n", "failures", "note"}. tau50 is None (with a note) when one
    class is absent, when failure does not rise with torque (b <= 0), or when tau50 lies outside the
    measured torque range (an extrapolation, not a threshold the data shows).
    """
    x, y = np.asarray(torque, float), np.asarray(failed, bool)
    if x.shape != y.shape or x.ndim != 1:
        raise InputError(f"failure_threshold: torque and failed must be [N] of one length, got {x.shape}, {y.shape}")
    keep = np.isfinite(x)
    x, y = x[keep], y[keep].astype(float)
    out = {"n": int(len(x)), "failures": int(y.sum()), "tau50": None, "slope": None, "a": None, "ci95": None, "note": ""}
    if len(x) < 4 or y.min() == y.max():
        out["note"] = "one class only (all failed or none failed): no threshold"
        return out
    a, b = _logistic_mle(x, y)
    out.update(a=float(a), slope=float(b))
    if b <= 0:
        out["note"] = "failure does not rise with torque here (slope <= 0)"
        return out
    t50 = -a / b
    if not x.min() <= t50 <= x.max():
        out["note"] = f"the 50% point {t50:.2f} N m lies outside the measured torques [{x.min():.2f}, {x.max():.2f}]"
        return out
    out["tau50"] = float(t50)
    rng = np.random.default_rng(seed)
    bs = []
    for _ in range(bootstrap):
        i = rng.integers(0, len(x), len(x))
        if y[i].min() == y[i].max():
            continue
        ab, bb = _logistic_mle(x[i], y[i])
        if bb > 0:
            bs.append(-ab / bb)
    if len(bs) >= 10:
        out["ci95"] = [float(np.percentile(bs, 2.5)), float(np.percentile(bs, 97.5))]
    return out


def binned_rate(x, flag, bins: int = 10) -> dict:
    """Rate of `flag` in `bins` equal-count bins of x: {"x_mid" (median x per bin), "rate", "lo", "hi"
    (Wilson 95 % interval), "n"}, each a list of length <= bins (empty bins dropped)."""
    x, f = np.asarray(x, float), np.asarray(flag, bool)
    keep = np.isfinite(x)
    x, f = x[keep], f[keep]
    if len(x) == 0:
        raise InputError("binned_rate: no finite values")
    order = np.argsort(x, kind="stable")
    out = {"x_mid": [], "rate": [], "lo": [], "hi": [], "n": []}
    z = 1.959963984540054
    for idx in np.array_split(order, min(bins, len(x))):
        n, k = len(idx), f[idx].sum()
        p = k / n
        c = (p + z * z / (2 * n)) / (1 + z * z / n)
        h = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
        lo, hi = min(max(c - h, 0.0), p), max(min(c + h, 1.0), p)  # exact at p = 0 or 1 up to rounding
        for key, v in (("x_mid", np.median(x[idx])), ("rate", p), ("lo", lo), ("hi", hi), ("n", n)):
            out[key].append(float(v) if key != "n" else int(v))
    return out


def paired_ratio(a, b, *, bootstrap: int = 2000, seed: int = 0, level: float = 0.95) -> dict:
    """How much smaller a is than b, pair by pair: the geometric mean of a_i / b_i over the pairs where
    both are finite and positive (e.g. two pickers' measured torques on the same tools).

    a, b: [N] positive values, paired by index. Returns {"ratio": exp(mean(log(a/b))) (< 1: a is lower),
    "ci95": [lo, hi] a percentile bootstrap over pairs (None below 3 pairs), "ci": the same at `level`
    (e.g. 0.9), "level", "lower": #pairs with a < b, "higher": #pairs with a > b, "n": #pairs used};
    ratio None when no pair is usable.
    """
    if not 0 < level < 1:
        raise InputError(f"paired_ratio: level must be in (0, 1), got {level!r}")
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape or a.ndim != 1:
        raise InputError(f"paired_ratio: a and b must be [N] of one length, got {a.shape}, {b.shape}")
    if not is_integer(bootstrap) or bootstrap < 0:
        raise InputError(f"paired_ratio: bootstrap must be an integer >= 0, got {bootstrap!r}")
    with np.errstate(invalid="ignore", divide="ignore"):
        keep = np.isfinite(a) & np.isfinite(b) & (a > 0) & (b > 0)
    lr = np.log(a[keep]) - np.log(b[keep])
    out = {"ratio": None, "ci95": None, "ci": None, "level": level, "lower": int(np.sum(lr < 0)),
           "higher": int(np.sum(lr > 0)), "n": int(len(lr))}
    if not len(lr):
        return out
    out["ratio"] = float(np.exp(lr.mean()))
    if len(lr) >= 3 and bootstrap:
        means = np.random.default_rng(seed).choice(lr, (bootstrap, len(lr))).mean(1)
        out["ci95"] = [float(np.exp(np.percentile(means, 2.5))), float(np.exp(np.percentile(means, 97.5)))]
        tail = 100 * (1 - level) / 2
        out["ci"] = [float(np.exp(np.percentile(means, tail))), float(np.exp(np.percentile(means, 100 - tail)))]
    return out


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper-Pearson) binomial interval of a success rate, k successes in n trials, at
    `level`: the beta quantiles, 0 and 1 at the ends (k = 0, k = n)."""
    from scipy.stats import beta

    a = 1 - level
    lo = 0.0 if k == 0 else float(beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi
