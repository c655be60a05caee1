"""From a study's outputs to analysis: the states a study stores (an E1 packing, an E3 reference
state) opened by grainwave.load as simulations that grainwave.linear and the contact records
analyse, giving the study's own numbers."""

from pathlib import Path

import numpy as np
import pytest

import grainwave
import grainwave.linear as gl
from test_errors import E1


@pytest.fixture(scope="module")
def e1_run(tmp_path_factory):
    return grainwave.run(E1, out=tmp_path_factory.mktemp("e1") / "run", threads=1)


def test_an_e1_packing_gives_the_study_s_pulse(e1_run):
    packing = e1_run.out / "samples" / "p1e-4_L4" / "s0001" / "packing.gwck"
    sim = grainwave.load(packing)
    assert isinstance(sim, grainwave.Simulation) and sim.dimension == 2
    assert len(sim) == e1_run.tables["samples"]["grains"][0]
    # the study's signal: the modal sum of the kick of the bottom wall (0) seen on the top wall
    # (1), impulse strength 1, the E1 defaults (no prestress term, rattlers kept)
    table = e1_run.tables["signals/p1e-4_L4"]
    times, theirs = table["time"], table["s0001"]
    ours = gl.modal_pulse(sim, 0, 1, times, initial_condition="impulse", strength=1.0)["signal"]
    scale = np.abs(theirs).max()
    assert scale > 0
    # the same matrix and eigensolver; only the summation order of the mode sum may differ
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * scale)
    # and its moduli: the sample's C11 (samples.csv)
    c = gl.moduli(sim)
    assert c["voigt"][0][0] == pytest.approx(e1_run.tables["samples"]["C11"][0], rel=1e-9)


def test_a_loaded_packing_steps_and_copies(e1_run):
    sim = grainwave.Simulation.load(e1_run.out / "samples" / "p1e-4_L4" / "s0001" / "packing.gwck")
    other = sim.copy()
    sim.step(10)
    other.step(10)
    assert sim.state_hash == other.state_hash


def test_a_study_s_own_checkpoint_is_refused_with_what_can_be_loaded(e1_run):
    with pytest.raises(ValueError, match=r"holds `experiment-e1/plan`.*an E1 packing\.gwck"):
        grainwave.load(e1_run.out)
    with pytest.raises(ValueError, match=r"holds `e1-sample-result`"):
        grainwave.load(e1_run.out / "samples" / "p1e-4_L4" / "s0001" / "result.gwck")


def test_an_e3_reference_state_gives_the_study_s_wall_loads(tmp_path):
    # the E3 pile example (66 disks, a fraction of a second): its relaxed reference state, and
    # the floor and side-wall loads the study reports, from the loaded state's contact records
    root = Path(__file__).resolve().parents[3]
    r = grainwave.run(root / "examples" / "e3-pile.toml", out=tmp_path / "e3", threads=1)
    case = r.summary["groups"][0]["cases"][0]
    (reference,) = (tmp_path / "e3" / "units").glob("*/reference.gwck")
    sim = grainwave.load(reference)
    assert len(sim) == case["grains"] and sim.step_count == case["steps"]
    c = sim.contacts()
    f_i = c["tangential_force"] - c["normal_force"][:, None] * c["normal"]
    load = [f_i[c["wall"] == w].sum(axis=0) for w in range(3)]  # floor, left, right
    weight = case["weight"]
    # the study sums the same contact forces (in another order): equal to rounding
    assert load[0][1] / weight == pytest.approx(case["floor_over_weight"], rel=1e-9)
    assert [load[1][0], -load[2][0]] == pytest.approx(case["side_wall_loads"], rel=1e-9)


# a small E2 compression (64 disks, half a second): full strain checkpoints every fifth, the
# ones between kept as references
E2 = {
    "experiment": "e2",
    "seed": 1,
    "packing": {"columns": 8, "rows": 8, "polydispersity": 0.2},
    "material": {"normal_stiffness": 2000.0, "restitution": 0.92, "tangential_stiffness_ratio": 0.5, "tangential_damping_ratio": 0.5, "friction": 0.2},
    "preparation": {"wall_mass": 0.01, "gravity": 0.01, "max_force": 1e-4},
    "loading": {"direction": "compression", "strain_rate": 1e-3, "final_strain": 1e-4, "checkpoint_strain": 2e-5, "sample_every": 20},
}


def test_e2_strain_checkpoints_load_in_full_and_references_name_their_base(tmp_path):
    r = grainwave.run(E2, out=tmp_path / "e2", threads=1)
    index = r.tables["checkpoints/index"]
    kinds = list(index["kind"])
    assert "full" in kinds and "reference" in kinds, kinds
    for k, kind in enumerate(kinds):
        path = r.out / index["file"][k]
        if kind == "full":
            sim = grainwave.load(path)
            # the state at that point of the loading: its step, all 64 disks
            assert sim.step_count == index["step"][k] and len(sim) == 64
        else:
            with pytest.raises(ValueError, match=r"kept as a reference .* load that full checkpoint \(`ck-000000.gwck`\)"):
                grainwave.load(path)
