"""Build the bundled default model ``energy_planner/data/b1_default.json``.

The default model is the paper's base model calibrated the way a user would calibrate
their own robot, on a simulated field campaign of a B1-class robot: the simulator's
default campaign (:class:`~energy_planner.simulate.CampaignConfig` defaults, seed 0, no
extra effect, realistic sensors: noise, spikes, odometry slip, IMU bias, battery sag)
is preprocessed, cut into 2 s windows and fitted jointly by
:func:`~energy_planner.calibration.fit_model` with 5-fold cross-validation by run.

Run it with::

    python -m energy_planner.calibration.default_model          # rewrites the bundled file
    python -m energy_planner.calibration.default_model --out other.json --seed 1

The simulator's truth is mechanistic physics, not a model, so there are no true
coefficients to compare with; the model's ``metadata`` records where it came from (package
version, the physics and its robot parameters, the campaign, the seed), the data counts,
the held-out errors, the campaign's noise floor and the critical grade of the forward
uphill cost (:func:`energy_planner.model.critical_grade`).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from energy_planner.calibration.fit import FitResult, fit_model
from energy_planner.energy.grade import critical_grade

__all__ = ["DEFAULT_PATH", "build_default_model", "main"]

#: Where the bundled default model lives.
DEFAULT_PATH = Path(__file__).resolve().parents[1] / "data" / "b1_default.json"
_COMMAND = "python -m energy_planner.calibration.default_model"


def build_default_model(
    seed: int = 0, config: Any = None, *, window: float = 2.0, n_splits: int = 5
) -> FitResult:
    """Simulate the campaign, preprocess it and fit the base model.

    Parameters
    ----------
    seed : int
        Simulator seed (the bundled model uses 0).
    config : CampaignConfig, optional
        Campaign (default: ``CampaignConfig()``, the simulator's default campaign).
    window : float
        Window length, s.
    n_splits : int
        Folds of the cross-validation by run.

    Returns
    -------
    FitResult
        With the model's ``metadata`` filled in (source, simulator, campaign, noise floor,
        critical grade).
    """
    from energy_planner.measurements import make_windows, preprocess
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    config = CampaignConfig() if config is None else config
    camp = simulate_campaign(seed=seed, effects=(), config=config)
    clean, _ = preprocess(camp.logs)
    windows = make_windows(clean, duration=window)
    noise = camp.noise_floor(windows)
    metadata = {
        "robot": "B1-class quadruped, about 50 kg, 0.3 m/s",
        "source": (
            f"base model fitted by `{_COMMAND}` on the simulator's default campaign "
            f"(seed {seed}, no extra effect, default sensors), {window:g} s windows"
        ),
        "simulator": {
            "package_version": _package_version(),
            "truth": (
                "mechanistic physics, energy_planner.simulate.Physics (gravity work through "
                "an efficiency, direction-dependent recovery, copper losses from the square "
                "of the leg forces, standing, swing, turning, ripple)"
            ),
            "robot_params": {r["name"]: r["value"] for r in camp.physics.params.table()},
        },
        "campaign": {
            "seed": seed,
            "effects": [],
            "n_runs": int(len(camp.runs)),
            "n_samples": int(len(camp.logs)),
            "slopes_deg": list(config.slopes_deg),
            "headings_deg": list(config.headings_deg),
            "motions": list(config.motions),
            "speeds_m_s": list(config.speeds),
            "yaw_rate_rad_s": config.yaw_rate,
            "repeats": config.repeats,
            "run_s": config.run_s,
            "rate_hz": config.rate_hz,
        },
        "noise_floor_w": round(noise.rmse_w, 3),
    }
    result = fit_model(windows, None, n_splits=n_splits, seed=seed, metadata=metadata)
    result.model.metadata["critical_grade"] = {
        k: (round(v, 4) if isinstance(v, float) else v)
        for k, v in critical_grade(result.model).items()
    }
    return result


def _package_version() -> str:
    from energy_planner import __version__

    return __version__


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point: fit and write the default model, print a summary."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_PATH, help="output JSON")
    parser.add_argument("--seed", type=int, default=0, help="simulator seed")
    parser.add_argument("--small", action="store_true", help="small campaign (quick look)")
    args = parser.parse_args(argv)
    config = None
    if args.small:
        from energy_planner.simulate import CampaignConfig

        config = CampaignConfig.small()
    t0 = time.perf_counter()
    result = build_default_model(args.seed, config)
    model = result.model
    # round to what the data supports (standard errors are well below 0.01 N)
    model.coefficients = {k: round(v, 2) for k, v in model.coefficients.items()}
    model.stderr = {k: float(f"{v:.3g}") for k, v in (model.stderr or {}).items()}
    model.metadata["critical_grade"] = {  # of the coefficients as saved
        k: (round(v, 4) if isinstance(v, float) else v) for k, v in critical_grade(model).items()
    }
    model.save(args.out)
    print(result.summary())
    cv = result.heldout
    floor = model.metadata["noise_floor_w"]
    print(
        f"\nheld-out power RMSE {cv.rmse_w:.2f} W = {cv.rmse_w / floor:.2f} x the campaign's "
        f"noise floor {floor:.2f} W"
    )
    cg = model.metadata["critical_grade"]
    print(
        f"critical grade of the forward uphill cost per metre (c(g)/g least): "
        f"g* = {cg['grade']:.4f} ({cg['slope_deg']:.2f} deg, {cg['method']}); "
        f"c(g*) = {cg['cost_n']:.1f} J/m, level {cg['level_cost_n']:.1f} J/m"
    )
    print(f"\nwrote {args.out} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
