"""Writing results: every file goes to a temporary name first and is renamed into place."""
import json
import math
import os
import tempfile
from pathlib import Path


def atomic_write(path, write):
    """Call ``write(tmp_path)`` then rename onto ``path``: readers never see half a file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + path.name, suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _clean(obj):
    """JSON-safe copy: NaN/inf -> None, numpy scalars -> Python numbers."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, "item"):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_json(path, data):
    def write(tmp):
        with open(tmp, "w") as fh:
            json.dump(_clean(data), fh, indent=2)
            fh.write("\n")
    atomic_write(path, write)


def write_csv(path, frame):
    atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))


def write_run(result, out_dir, plot=True):
    """``profile.csv``, ``summary.json``, ``speed.png`` (and ``advice.csv``) of one run into ``out_dir``."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "profile.csv", result.profile)
    write_json(out_dir / "summary.json", result.summary)
    if result.das is not None:
        write_csv(out_dir / "advice.csv", result.das[0])
    if plot:
        from .plots import speed_plot
        atomic_write(out_dir / "speed.png", lambda tmp: speed_plot(result, tmp))
    return out_dir


def write_front(table, results, out_dir, meta, plot=True, weighted=None):
    """``pareto.csv``, ``pareto.json`` and the two plots of a front (and ``pareto_weighted.csv``)."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "pareto.csv", table)
    if weighted is not None:
        write_csv(out_dir / "pareto_weighted.csv", weighted)
    write_json(out_dir / "pareto.json", meta)
    if plot:
        import numpy as np

        from .plots import pareto_plot, profiles_plot
        title = f"{meta['train']} - {meta['from']} to {meta['to']} (K = {meta['points']})"
        atomic_write(out_dir / "pareto.png", lambda tmp: pareto_plot(table, tmp, title, weighted))
        picks = sorted(set(np.linspace(0, len(results) - 1, min(5, len(results))).round().astype(int)))
        atomic_write(out_dir / "pareto_profiles.png",
                     lambda tmp: profiles_plot([results[i] for i in picks], tmp, title))
    return out_dir
