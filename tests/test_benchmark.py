"""The smoothing benchmark (`foam-mj bench`, foam_mj/benchmark.py): what makes it exit 1."""

from __future__ import annotations

from foam_mj.benchmark import not_certified, obstacle_rosary
from foam_mj.smoothing import OptimalSmoother


def test_an_uncertified_optimum_is_a_regression_the_exit_status_reports():
    """Every gap of the benchmark is measured to the optimal smoother's point, which its tables call the certified
    optimum; the exit status (CI's check) was 1 only for a path outside its hatches or a method beating the optimum,
    so an optimal smoother that stopped certifying left CI green (the tables showed 'NO' in one column). Here the
    real smoother on the benchmark's rosary, certified with its defaults and uncertified when cut to one SCP step,
    in the shape of the benchmark's result: only the uncertified ones are listed (each listed one makes exit 1)."""
    oracle, rosary, _ = obstacle_rosary()
    oracle.close()
    good = OptimalSmoother().smooth(rosary)
    cut = OptimalSmoother(max_iter=1, restarts=0).smooth(rosary)
    assert good.info["certified"] and not cut.info["certified"]

    def result(optimal, f_opt, sv_opt) -> dict:
        gaps = {"obstacle": {"optimum": {"certified": bool(f_opt.info["certified"])}, "sv_optimum": {"certified": bool(sv_opt.info["certified"])}}}
        return {"methods": {"HS": {"per_run": [{"stop_reason": "stall"}]}, "optimal": {"per_run": [r.summary() for r in optimal]}},
                "scene_gaps": gaps, "hatch_violations": []}

    assert not_certified(result([good, good], good, good)) == []
    assert not_certified(result([good, cut], good, good)) == [f"optimal run 1: {cut.stop_reason}"]
    assert not_certified(result([good], cut, good)) == ["obstacle optimum"]
    assert not_certified(result([good], good, cut)) == ["obstacle sv_optimum"]
