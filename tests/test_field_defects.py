"""Regression tests of the defects found by the field runs (wrong answers, round trips,
readers that trusted their input, messages that exploded)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from multiloop.cli import main
from multiloop.inputs import load_mechanism
from multiloop.kin.forces import forces, kinetic_energy, potential_energy
from multiloop.kin.solve import solve
from multiloop.topo.io import load, mechanism_to_dict
from multiloop.topo.model import Link, MechanismBuilder

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "catalogue/mechanisms/four_bar.toml"


def _canonical(m) -> str:
    return json.dumps(mechanism_to_dict(m), sort_keys=True)


# --- 1. convert writes files multiloop reads back ---------------------------------------
@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_convert_of_a_force_table_reads_back(tmp_path, capsys, suffix):
    out = tmp_path / f"out{suffix}"
    assert main(["convert", "crank_slider_loaded", str(out)]) == 0
    assert main(["analyse", str(out)]) == 0, capsys.readouterr().err
    assert _canonical(load(out)) == _canonical(load_mechanism("crank_slider_loaded"))


# --- 2. a massless link's moment of inertia ---------------------------------------------
def _rocker_inertia_only(mass):
    b = MechanismBuilder.from_mechanism(load(FOUR_BAR))
    b.links = [Link(lk.name, lk.is_frame, mass, lk.cg, 0.01, lk.color) if lk.name == "rocker" else lk
               for lk in b.links]
    b.drivers = [type(d)(d.joint, d.links, 20.0, d.acceleration) for d in b.drivers]
    return b.build()


def test_massless_link_inertia_loads_the_balancing_moment():
    """M_b ω = d(T)/dt (energy method; no gravity, no applied load) for a rocker with
    J = 0.01 kg m² and no mass; the field value was |M_b| up to 4.03 N m."""
    m = _rocker_inertia_only(None)
    q = np.radians(np.arange(0.0, 360.0, 5.0))[:, None]
    fr = forces(m, q, accelerations=np.zeros(1))
    ok = fr.ok
    assert ok.sum() > 60
    w, h = 20.0, 1e-6

    def energy(t):
        s = solve(m, q + w * t, derivatives=True, input_rates=np.array([w]))
        return kinetic_energy(s) + potential_energy(s)
    dE = (energy(h) - energy(-h)) / (2 * h)
    mb = fr.balancing[:, 0]
    np.testing.assert_allclose(mb[ok] * w, dE[ok], atol=1e-5 * np.abs(dE).max())
    assert 3.9 < np.abs(mb[ok]).max() < 4.2
    # and the tiny-mass route agrees with the massless one
    tiny = forces(_rocker_inertia_only(1e-9), q, accelerations=np.zeros(1))
    np.testing.assert_allclose(tiny.balancing[ok], fr.balancing[ok], atol=1e-6)
