"""Run the Snakemake workflow in a throw-away copy of the repository."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
COPY = ("Snakefile", "config.yaml", "profiles", "workflow", "notebooks", "data")

# Small but complete: every stage runs (both PSO settings, the rig variant, the blind variant), with one PSO seed and
# fewer particles, grid points, blind cases and reference-fit evaluations.
SMALL = {
    "pso": {"n_particles": 10, "iterations": 50, "seeds": [0]},
    "rig": {"variants": {"paper_truth": {"pso_seeds": [0]}}},
    "lsm": {"max_iterations": 60},
    "identifiability": {"n_grid": 5, "refine_rel": [0.1], "max_iterations": 10},
    "diagnose": {"n_random": 200, "n_random_deep": 50, "n_starts": 2, "max_iter": 60},
    # the key's reference fits (scipy TRF through the rig, one call per evaluation) were most of the build
    "blind": {"n_per_class": 1, "classes": ["none", "hall_offset", "remanent_start"], "reference": {"max_nfev": 60},
              "variants": {"bipolar2": {"classes": ["none", "hall_offset"], "n_per_class": 1}}},
    "external": {"n_particles": 10, "iterations": 5, "lsm_starts": 1, "lsm_max_iterations": 20},
    # --model auto of the external fits compares two quick variants (anisotropic costs a quadrature per step)
    "ja": {"auto": {"variants": ["ja", "venkataraman"]}},
    # the real-cores benchmark on one core, as Hall sweeps: 5 diagnoses
    "realcores": {"cores": ["mnzn_ferrite_L1"], "protocols": ["hall"]},
    # the gadolinium temperature laws (a joint fit of five real loops, minutes of CPU) are left out of `all`
    "gdlaws": {"in_all": False},
}


def make_copy(dest: Path, overrides: dict | None = None) -> Path:
    """Copy what the workflow needs into ``dest``; deep-merge ``overrides`` into its config.yaml."""
    dest.mkdir(parents=True, exist_ok=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".ipynb_checkpoints")
    for name in COPY:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=ignore)
        else:
            shutil.copy2(src, dest / name)
    if overrides:
        cfg = yaml.safe_load((dest / "config.yaml").read_text())
        _merge(cfg, overrides)
        (dest / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    return dest


def _merge(base: dict, over: dict) -> None:
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            _merge(base[k], v)
        else:
            base[k] = v


def snakemake(workdir: Path, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    env = dict(os.environ, NUMBA_NUM_THREADS="1", MPLBACKEND="agg")
    cmd = [sys.executable, "-m", "snakemake", "--directory", str(workdir), "--snakefile",
           str(workdir / "Snakefile"), *args]
    return subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=timeout, env=env)


def tree_digest(folder: Path) -> dict:
    """{relative path: bytes} of every file below folder (logs excluded: they hold timings)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and "logs" not in p.relative_to(folder).parts:
            out[str(p.relative_to(folder))] = p.read_bytes()
    return out


def small_copy(dest: Path) -> Path:
    """A copy with SMALL merged into its config and one third-party file."""
    wd = make_copy(dest, SMALL)
    cfg = yaml.safe_load((wd / "config.yaml").read_text())
    # one third-party file is enough for the appendix (the ferrite file holds four loops)
    cfg["external"]["sources"] = {"hiperco50": cfg["external"]["sources"]["hiperco50"]}
    (wd / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    return wd
