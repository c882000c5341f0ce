"""Simulated runs of the shipped scenarios, cached so that several tests share one run."""
from functools import lru_cache
from pathlib import Path

from formation_control.core import scenario, simulator
from formation_control.core.control import Controller

CONFIG = Path(__file__).resolve().parents[1] / 'config'
SEEDS = (1, 2, 3)


@lru_cache(maxsize=None)
def run_of(name, seed, overrides=()):
    sc = scenario.load(CONFIG / f'{name}.yaml', overrides, seed=seed)
    return simulator.simulate(sc)


def views(run):
    """The controller's particle view at every recorded instant."""
    ctrl = Controller(run.sc)
    return ctrl, [ctrl.view(X, U[1]) for X, U in zip(run.X, run.U)]
