"""Per-sample update cost of LWPR with ~350 receptive fields on 9-D inputs (ho2018 Section 2.3).

Ho et al. 2018 learn the forward transition model ``(p_k, du_k, u_k) -> dp_k`` of a two-segment
soft arm with LWPR: 9 inputs (tip position, chamber-volume step, chamber volumes) and 3 outputs;
their pre-trained model had 352 receptive fields. This script feeds a synthetic stream of that
shape (chamber volumes wandering smoothly in [0, 1]^3 and a smooth made-up forward kinematics)
to :class:`agents.learners.LWPR`:

1. **warm-up** (not timed): samples until the model has ``--fields`` receptive fields (per
   output), so that the timed updates see a trained model of about that size;
2. **vectorised**: ``LWPR.update`` on the next ``--steps`` samples; the activations of all fields
   come from one numpy computation over the stacked centres and metrics, and the activated fields
   (``w > 0.001``) are updated together;
3. **per-field loop**: a plain-numpy version of the same algorithm started from a copy of the
   warmed-up model, as the reference library is written: a Python loop over the fields computes
   each activation and updates each activated field with 1-D numpy operations. It runs on the
   first ``--reference-steps`` of the same samples.

The report gives the field count before and after, the mean number of activated fields, the mean,
95th percentile and maximum microseconds per ``update`` call, updates per second, the ratio
per-field / vectorised, and the largest difference between the predictions the two versions
return during the same updates (a correctness check of the vectorisation; the field counts must
agree). Timings are wall-clock (``time.perf_counter``), single process, one core: the script
sets ``OPENBLAS_NUM_THREADS=1`` (and the OpenMP/MKL equivalents) unless they are already set;
the numbers depend on the machine and its load.

Example::

    PYTHONPATH=. python bench/lwpr_speed.py
    PYTHONPATH=. python bench/lwpr_speed.py --outputs 3 --fields 139 --json lwpr_speed.json
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agents.learners import LWPR  # noqa: E402
from agents.learners.lwpr import UPDATE_CUTOFF  # noqa: E402
from soft_gym._cli import CommandParser, HelpFormatter  # noqa: E402

NORM_IN = np.r_[np.full(3, 0.3), np.full(3, 0.03), np.full(3, 0.3)]   # p, du, u scales


def forward_kinematics(u: np.ndarray) -> np.ndarray:
    """A smooth made-up map from chamber volumes (..., 3) in [0, 1] to a tip position (..., 3)."""
    u1, u2, u3 = u[..., 0], u[..., 1], u[..., 2]
    return np.stack([0.6 * np.sin(2.0 * u1 - u3) + 0.3 * u2,
                     0.6 * np.cos(2.0 * u2 + 0.5 * u1) - 0.2 * u3,
                     0.5 * u3 + 0.3 * np.sin(3.0 * u1 * u2)], axis=-1)


def make_stream(steps: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Inputs ``[p_k, du_k, u_k]`` (steps, 9) and targets ``dp_k`` (steps, 3)."""
    rng = np.random.default_rng(seed)
    u = np.empty((steps + 1, 3))
    u[0] = 0.5
    velocity = np.zeros(3)
    for k in range(steps):
        velocity = 0.8 * velocity + 0.02 * rng.standard_normal(3)
        following = np.abs(u[k] + velocity)              # reflect at 0 and 1
        u[k + 1] = 1.0 - np.abs(1.0 - following)
    p = forward_kinematics(u[:-1])
    X = np.hstack([p, u[1:] - u[:-1], u[:-1]])
    return X, forward_kinematics(u[1:]) - p


class LoopLWPR:
    """The update of :class:`LWPR`, written field by field (the non-vectorised reference).

    Starts from a copy of ``model`` (read back from its saved file) and keeps every receptive
    field as a dict of 1-D/2-D arrays in a Python list per output; ``update`` loops over the
    fields, computes each activation and updates the activated ones one at a time.
    """

    def __init__(self, model: LWPR) -> None:
        self.m = model
        d = model.input_dim
        self.mask = np.eye(d, dtype=bool) if model.diag_only else np.triu(np.ones((d, d), bool))
        self.init_M = np.linalg.cholesky(model.init_d).T
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "model.npz"
            model.save(path)
            with np.load(path) as data:
                stored = {name: data[name] for name in data.files}
        self.names = [key.split("/", 1)[1] for key in stored
                      if key.startswith("out0/") and key != "out0/n_pruned"]
        self.shapes = {name: stored[f"out0/{name}"].shape[1:] for name in self.names}
        self.outputs = []
        for i in range(model.output_dim):
            count = len(stored[f"out{i}/c"])
            self.outputs.append([{name: stored[f"out{i}/{name}"][k].copy()
                                  for name in self.names} for k in range(count)])

    @property
    def fields_per_output(self) -> tuple[int, ...]:
        return tuple(len(fields) for fields in self.outputs)

    def update(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        xn = np.asarray(x, float) / self.m.norm_in
        yn = np.asarray(y, float).reshape(-1) / self.m.norm_out
        prediction = [self._update_output(fields, xn, float(yn[i]))
                      for i, fields in enumerate(self.outputs)]
        return np.array(prediction) * self.m.norm_out

    def _update_output(self, fields: list[dict], xn: np.ndarray, yn: float) -> float:
        m = self.m
        if not fields:
            fields.append(self._new_field(xn, yn, None))
            return 0.0
        w_max = w_sec = 0.0
        i_max = i_sec = -1
        weighted = total = 0.0
        for k, rf in enumerate(fields):
            dx = xn - rf["c"]
            w = math.exp(-0.5 * float(dx @ rf["D"] @ dx))
            if w > w_sec:
                if w > w_max:
                    i_sec, w_sec, i_max, w_max = i_max, w_max, k, w
                else:
                    i_sec, w_sec = k, w
            if w > UPDATE_CUTOFF:
                y_local = self._update_field(rf, w, xn, yn)
                if rf["trustworthy"]:
                    weighted += w * y_local
                    total += w
        if w_max <= m.w_gen:
            template = fields[i_max] if (w_max > 0.1 * m.w_gen
                                         and fields[i_max]["trustworthy"]) else None
            fields.append(self._new_field(xn, yn, template))
        elif w_sec > m.w_prune:
            narrower = i_max if np.trace(fields[i_max]["D"]) > np.trace(fields[i_sec]["D"]) \
                else i_sec
            fields[narrower] = fields[-1]
            fields.pop()
        return weighted / total if total > 0.0 else 0.0

    def _new_field(self, xn: np.ndarray, yn: float, template: dict | None) -> dict:
        m = self.m
        rf = {name: np.zeros(shape, bool if name == "trustworthy" else
                             (np.int64 if name == "n_reg" else float))
              for name, shape in self.shapes.items()}
        if template is None:
            rf["M"], rf["D"] = self.init_M.copy(), m.init_d.copy()
            rf["alpha"], rf["beta0"] = m.init_alpha.copy(), yn
            n_reg = min(2, m.max_projections)
        else:
            rf["M"], rf["D"] = template["M"].copy(), template["D"].copy()
            rf["alpha"], rf["beta0"] = template["alpha"].copy(), float(template["beta0"])
            n_reg = int(template["n_reg"])
        rf["c"] = xn.copy()
        rf["b"] = np.where(self.mask, np.log(rf["alpha"] + 1e-10), 0.0)
        rf["n_reg"] = n_reg
        rf["SSs2"][:] = m.init_s2
        rf["sum_w"][:] = 1e-10
        rf["lam"][:] = m.init_lambda
        rf["n_data"][:n_reg] = 1e-10
        for j in range(n_reg):
            rf["U"][j, j] = rf["P"][j, j] = 1.0
        return rf

    def _update_field(self, rf: dict, w: float, xn: np.ndarray, yn: float) -> float:
        m = self.m
        d, nr = xn.size, int(rf["n_reg"])
        lam = rf["lam"][:nr]
        memory = rf["sum_w"][0] * lam[0]
        total = memory + w
        rf["mean_x"] = (memory * rf["mean_x"] + w * xn) / total
        z = xn - rf["mean_x"]
        rf["var_x"] = (memory * rf["var_x"] + w * z**2) / total
        rf["beta0"] = (memory * rf["beta0"] + w * yn) / total
        e0 = yn - rf["beta0"]

        U, P = rf["U"], rf["P"]
        s, zres, current = np.zeros(nr), np.empty((nr, d)), z
        for j in range(nr):
            zres[j] = current
            s[j] = U[j] @ current
            current = current - P[j] * s[j]
        e_cv = e0 - np.cumsum(rf["beta"][:nr] * s)
        target = np.concatenate(([e0], e_cv[:-1]))
        rf["sum_w"][:nr] = rf["sum_w"][:nr] * lam + w
        for j in range(nr):
            a_zt = rf["SXresYres"][j] * (0.9 + 0.1 * lam[j]) + w * target[j] * zres[j]
            rf["SXresYres"][j] = a_zt
            norm2 = a_zt @ a_zt
            if norm2 > 1e-24:
                U[j] = a_zt / math.sqrt(norm2)
            rf["SSs2"][j] = lam[j] * rf["SSs2"][j] + w * s[j] * s[j]
            rf["SSYres"][j] = lam[j] * rf["SSYres"][j] + w * s[j] * target[j]
            rf["SSXres"][j] = lam[j] * rf["SSXres"][j] + w * s[j] * zres[j]
            rf["beta"][j] = rf["SSYres"][j] / rf["SSs2"][j]
            P[j] = rf["SSXres"][j] / rf["SSs2"][j]
        rf["SSp"] = lam[nr - 1] * rf["SSp"] + np.sum((w * s)**2 / rf["SSs2"][:nr])

        s, current = np.zeros(nr), z
        for j in range(nr):
            s[j] = U[j] @ current
            current = current - P[j] * s[j]
        rf["s"][:nr] = s
        n_data = rf["n_data"]
        n_used = nr if n_data[nr - 1] > 2 * d else nr - 1
        y_fit = float(rf["beta"][:n_used] @ s[:n_used])
        e = e0 - y_fit
        e_cv_used = e_cv[n_used - 1] if n_used > 0 else e0
        if n_data[0] * (1.0 - lam[0]) > 0.1:
            rf["sum_e2"] = rf["sum_e2"] * lam[nr - 1] + w * e * e
            rf["sum_e_cv2"][:nr] = rf["sum_e_cv2"][:nr] * lam + w * e_cv**2
        if n_data[0] > 2 * d:
            rf["trustworthy"] = True
        y_local = y_fit + float(rf["beta0"])

        if m.update_d:
            self._update_metric(rf, w, xn, e, e_cv_used)
        self._add_projection(rf)
        nr = int(rf["n_reg"])
        rf["n_data"][:nr] = rf["n_data"][:nr] * rf["lam"][:nr] + 1.0
        rf["lam"][:nr] = m.tau_lambda * rf["lam"][:nr] + m.final_lambda * (1.0 - m.tau_lambda)
        return y_local

    def _update_metric(self, rf: dict, w: float, xn: np.ndarray, e: float, e_cv: float) -> None:
        m, mask = self.m, self.mask
        d, nr = xn.size, int(rf["n_reg"])
        lam, n_data = rf["lam"][:nr], rf["n_data"][:nr]
        ok = n_data * (1.0 - lam[0]) > 0.1
        if not ok[0]:
            return
        s, H, r = rf["s"][:nr], rf["H"][:nr], rf["r"][:nr]
        psi = np.where(ok, s / rf["SSs2"][:nr], 0.0)
        h = w * np.sum(psi * s)
        W = rf["sum_w"][0]
        E = rf["sum_e_cv2"][nr - 1 if (nr == 1 or n_data[nr - 1] > 2 * d) else nr - 2]
        damping = min(1.0, (rf["sum_e2"] / (E + 1e-10))**4)
        dJ1dw = (e_cv**2 - E / W - 2.0 * np.sum(psi * e * H + psi**2 * r)) / W
        M, D = rf["M"], rf["D"]
        dx = xn - rf["c"]
        dqdM = 2.0 * np.outer(M @ dx, dx)
        dwdM = -0.5 * w * dqdM
        gamma = m.penalty / d
        dJdM = np.where(mask, (w / W) * (4.0 * gamma * (M @ D)) + dJ1dw * dwdM, 0.0)
        alpha = rf["alpha"]
        if m.meta:
            Pse = psi * e
            ddJ1dwdw = (2.0 * (e * e * h / w - e_cv**2 / W) + E / W**2
                        + 4.0 * np.sum((Pse / W + psi * (s @ Pse)) * H)) / W
            ddwdMdM = 0.25 * w * dqdM**2 - w * dx[None, :]**2
            ddJ2dMdM = 4.0 * gamma * (np.diag(D)[None, :] + M**2 + np.sum(M**2, axis=1)[:, None])
            ddJdMdM = (w / W) * ddJ2dMdM + dJ1dw * ddwdMdM + ddJ1dwdw * dwdM**2
            b = np.clip(rf["b"] - np.clip(m.meta_rate * damping * dJdM * rf["h"], -0.1, 0.1),
                        -10.0, 10.0)
            rf["b"][mask] = b[mask]
            alpha[mask] = np.exp(b[mask])
            decay = np.maximum(0.0, 1.0 - alpha * ddJdMdM * damping)
            rf["h"][mask] = (rf["h"] * decay - alpha * damping * dJdM)[mask]
        delta = alpha * damping * dJdM
        too_large = mask & (delta > 0.1 * np.max(np.abs(M[mask])))
        alpha[too_large] *= 0.5
        step = mask & ~too_large
        M[step] -= delta[step]
        rf["D"] = M.T @ M
        gain = w / (1.0 - h) * damping
        H[ok] = lam[ok] * H[ok] + gain * e_cv * s[ok]
        r[ok] = lam[ok] * r[ok] + gain * w * e_cv**2 * s[ok]**2

    def _add_projection(self, rf: dict) -> None:
        m = self.m
        nr = int(rf["n_reg"])
        if nr >= m.max_projections or nr < 2:
            return
        sum_e_cv2, sum_w, n_data, lam = rf["sum_e_cv2"], rf["sum_w"], rf["n_data"], rf["lam"]
        mse = sum_e_cv2[nr - 1] / sum_w[nr - 1] + 1e-10
        mse_before = sum_e_cv2[nr - 2] / sum_w[nr - 2] + 1e-10
        if (mse < m.add_threshold * mse_before and n_data[nr - 1] > 0.99 * n_data[0]
                and n_data[nr - 1] * (1.0 - lam[nr - 1]) > 0.5):
            rf["U"][nr, nr] = rf["P"][nr, nr] = 1.0
            rf["SSp"] = 0.0
            rf["n_reg"] = nr + 1


def summary(seconds: np.ndarray) -> dict[str, float]:
    us = 1e6 * np.asarray(seconds)
    return {"mean_us": float(us.mean()), "p95_us": float(np.percentile(us, 95)),
            "max_us": float(us.max()), "updates_per_s": float(1e6 / us.mean())}


def main(argv: list[str] | None = None) -> dict:
    parser = CommandParser(
        description=__doc__.split("\n\n")[0] + "\n\nSee the module docstring for details.",
        formatter_class=HelpFormatter)
    parser.add_argument("--fields", type=int, default=350,
                        help="receptive fields (per output) to reach before timing")
    parser.add_argument("--outputs", type=int, default=1, choices=(1, 2, 3),
                        help="output dimensions learned (dp_k has 3)")
    parser.add_argument("--steps", type=int, default=1000, help="timed vectorised updates")
    parser.add_argument("--reference-steps", type=int, default=200,
                        help="timed per-field-loop updates, the first of the same samples")
    parser.add_argument("--max-warmup", type=int, default=30000,
                        help="most warm-up samples spent reaching --fields")
    parser.add_argument("--init-d", type=float, default=0.7,
                        help="initial distance metric (times the identity, normalised inputs)")
    parser.add_argument("--w-gen", type=float, default=0.2, help="field creation threshold")
    parser.add_argument("--full-metric", action="store_true",
                        help="adapt full (upper-triangular) metrics instead of diagonal ones")
    parser.add_argument("--meta", action="store_true", help="meta-learn the learning rates")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample stream")
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    args = parser.parse_args(argv)
    if min(args.fields, args.steps, args.reference_steps, args.max_warmup) < 1:
        parser.error("fields, steps, reference-steps and max-warmup must be >= 1")

    X, Y = make_stream(args.max_warmup + args.steps, args.seed)
    Y = Y[:, :args.outputs]
    model = LWPR(9, args.outputs, init_d=args.init_d, init_alpha=50.0, w_gen=args.w_gen,
                 diag_only=not args.full_metric, meta=args.meta, norm_in=NORM_IN,
                 norm_out=Y[:2000].std(axis=0))
    warmup_start = time.perf_counter()
    warmup = 0
    while warmup < args.max_warmup and min(model.fields_per_output) < args.fields:
        model.update(X[warmup], Y[warmup])
        warmup += 1
    warmup_s = time.perf_counter() - warmup_start
    fields_before = model.fields_per_output
    reference = LoopLWPR(model)
    stream_X, stream_Y = X[warmup:warmup + args.steps], Y[warmup:warmup + args.steps]

    activated, t_vec, predictions = [], [], []
    for k in range(args.steps):
        centres, metrics = model.receptive_fields(0)
        dx = stream_X[k] - centres
        w = np.exp(-0.5 * np.einsum("ki,kij,kj->k", dx, metrics, dx))
        activated.append(int(np.sum(w > UPDATE_CUTOFF)))
        t0 = time.perf_counter()
        out = model.update(stream_X[k], stream_Y[k])
        t_vec.append(time.perf_counter() - t0)
        if k < args.reference_steps:
            predictions.append(out)
        if k + 1 == min(args.reference_steps, args.steps):
            fields_at_reference_end = model.fields_per_output
    fields_after = model.fields_per_output

    t_ref, max_diff = [], 0.0
    for k in range(min(args.reference_steps, args.steps)):
        t0 = time.perf_counter()
        out = reference.update(stream_X[k], stream_Y[k])
        t_ref.append(time.perf_counter() - t0)
        max_diff = max(max_diff, float(np.max(np.abs(out - predictions[k]))))
    vectorised, loop = summary(np.array(t_vec)), summary(np.array(t_ref))
    same_fields = reference.fields_per_output == fields_at_reference_end

    results = {
        "settings": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "warmup_samples": warmup, "warmup_s": warmup_s,
        "fields_before": fields_before, "fields_after": fields_after,
        "activated_fields_mean": float(np.mean(activated)),
        "vectorised": vectorised, "per_field_loop": loop,
        "ratio_loop_over_vectorised": loop["mean_us"] / vectorised["mean_us"],
        "max_abs_prediction_difference": max_diff, "same_field_counts": same_fields,
        "threads": {v: os.environ.get(v) for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")},
        "versions": {"python": platform.python_version(), "numpy": np.__version__},
        "machine": platform.platform(),
    }

    metric = "full" if args.full_metric else "diagonal"
    print(f"LWPR, 9-D inputs, {args.outputs} output(s), {metric} metrics"
          f"{', meta learning' if args.meta else ''}; OPENBLAS_NUM_THREADS="
          f"{os.environ.get('OPENBLAS_NUM_THREADS')}")
    print(f"warm-up: {warmup} samples in {warmup_s:.1f} s; receptive fields per output "
          f"{fields_before} before, {fields_after} after the timed updates; "
          f"{results['activated_fields_mean']:.1f} activated (w > {UPDATE_CUTOFF}) per update "
          f"(output 0)")
    print(f"{'':22s}{'mean us':>10s}{'p95 us':>10s}{'max us':>10s}{'updates/s':>11s}"
          f"{'steps':>7s}")
    for name, result, count in (("vectorised", vectorised, len(t_vec)),
                                ("per-field loop", loop, len(t_ref))):
        print(f"{name:22s}{result['mean_us']:10.0f}{result['p95_us']:10.0f}"
              f"{result['max_us']:10.0f}{result['updates_per_s']:11.0f}{count:7d}")
    print(f"ratio per-field loop / vectorised: {results['ratio_loop_over_vectorised']:.1f}x")
    print(f"max |prediction difference| {max_diff:.2e} over {len(t_ref)} updates; field counts "
          f"{'agree' if same_fields else 'DIFFER'}")
    verdict = "meets" if vectorised["updates_per_s"] >= 500 else "BELOW"
    print(f"{vectorised['updates_per_s']:.0f} updates/s: {verdict} the target of 500 updates/s")
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
