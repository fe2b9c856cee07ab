"""The scenario's ``faults:`` section: validation at load, resolution, common random numbers."""

from __future__ import annotations

import textwrap

import pytest

from harness.scenarios.faults import FaultSpec, fault_count, resolve_faults
from harness.scenarios.spec import ScenarioError, parse_scenario

BASE = """\
name: faults
fidelity: swarm
duration_s: 60
fleet:
  - {role: idle, count: 10}
roles:
  idle: {}
"""


def scenario(faults: str):
    return parse_scenario(BASE + textwrap.dedent(faults), "s.yaml")


def test_a_fraction_of_the_fleet_is_drawn_from_the_seed_alone():
    s = scenario(
        """
        faults:
          - {kind: [crash, radio], fraction: 0.3, between_s: [10, 50]}
        """
    )
    first = s.faults(seed=4)
    assert len(first) == 3 and all(10 <= f.time_s <= 50 for f in first)
    assert [f.kinds for f in first] == [("crash", "radio")] * 3
    assert s.faults(seed=4) == first  # same seed, same faults
    assert {f.vehicle for f in s.faults(seed=5)} != {f.vehicle for f in first} or [
        f.time_s for f in s.faults(seed=5)
    ] != [f.time_s for f in first]
    # an entry added after it does not shift its draws (common random numbers)
    more = scenario(
        """
        faults:
          - {kind: [crash, radio], fraction: 0.3, between_s: [10, 50]}
          - {kind: land, vehicle: 1, at_s: 55}
        """
    ).faults(seed=4)
    assert [f for f in more if f.entry == 0] == first


def test_faults_are_ordered_by_time_and_a_vehicle_is_lost_once():
    s = scenario(
        """
        faults:
          - {kind: land, vehicle: 2, at_s: 40}
          - {kind: crash, vehicle: 2, at_s: 20}
          - {kind: radio_tx, vehicle: 3, at_s: 5}
          - {kind: radio, vehicle: 3, at_s: 6}
          - {kind: radio_rx, vehicle: 3, at_s: 7}
          - {kind: [land, radio_tx], vehicle: 2, at_s: 30}
        """
    )
    faults = s.faults(seed=0)
    assert [(f.vehicle, f.kinds, f.time_s) for f in faults] == [
        (2, ("radio_tx",), 5.0),
        (2, ("radio",), 6.0),  # its receiver still goes off
        (1, ("crash",), 20.0),
        (1, ("radio_tx",), 30.0),  # the landing of a crashed vehicle is dropped, not the radio
    ]
    assert faults[2].record(20.05) == {
        "vehicle": "vehicle2",
        "kind": "crash",
        "time_s": 20.05,
        "due_s": 20.0,
        "entry": 1,
        "applied": True,
    }
    # a run that ends before a fault is due reports it with no time, not applied
    assert faults[3].record(None) == {
        "vehicle": "vehicle2",
        "kind": "radio_tx",
        "time_s": None,
        "due_s": 30.0,
        "entry": 5,
        "applied": False,
    }


@pytest.mark.parametrize(
    ("entry", "field", "words"),
    [
        ("{kind: crash, vehicle: 11, at_s: 5}", "faults.0.vehicle", "does not exist"),
        ("{kind: crash, vehicle: 1, at_s: 61}", "faults.0.at_s", "after the run's end"),
        ("{kind: crash, fraction: 0.1, between_s: [5, 70]}", "faults.0.between_s", "run's end"),
        ("{kind: crash, fraction: 1.5, at_s: 5}", "faults.0.fraction", "less than or equal"),
        ("{kind: crash, fraction: -0.1, at_s: 5}", "faults.0.fraction", "greater than"),
        ("{kind: explode, vehicle: 1, at_s: 5}", "faults.0.kind", "crash"),
        ("{kind: crash, vehicle: 1, fraction: 0.5, at_s: 5}", "faults.0", "one"),
        ("{kind: crash, vehicle: 1}", "faults.0", "at_s"),
        ("{kind: crash, vehicle: 1, between_s: [9, 3]}", "faults.0.between_s", "from <= to"),
        ("{kind: crash, vehicle: 0, at_s: 5}", "faults.0.vehicle", "greater than"),
        ("{kind: crash, vehicle: 1, at_s: 5, when: 3}", "faults.0.when", "unknown key"),
    ],
)
def test_bad_faults_fail_at_load_naming_the_field(entry, field, words):
    with pytest.raises(ScenarioError) as err:
        scenario(f"faults:\n  - {entry}\n")
    assert field in str(err.value) and words in str(err.value), str(err.value)


@pytest.mark.parametrize(
    ("rounding", "u", "count"),
    [("stochastic", 0.49, 1), ("stochastic", 0.51, 0), ("nearest", 0.0, 1), ("floor", 0.0, 0),
     ("ceil", 0.9, 1)],
)  # fmt: skip
def test_a_fraction_rounds_as_asked(rounding, u, count):
    assert fault_count(0.1, 5, rounding, u) == count  # seed 003's 10 % of 5 vehicles


def test_stochastic_rounding_keeps_the_mean_fraction():
    entry = FaultSpec(kind="crash", fraction=0.1, between_s=(0.0, 10.0))
    lost = [len(resolve_faults([entry], 5, seed)) for seed in range(2000)]
    assert abs(sum(lost) / len(lost) - 0.5) < 0.05
    assert set(lost) == {0, 1}


def test_a_sweep_sets_fault_values_and_a_bad_one_fails_at_planning(tmp_path):
    from harness.sweep.spec import SweepError, plan_sweep
    from harness.sweep.trial import build_scenario

    (tmp_path / "s.yaml").write_text(
        BASE + "faults:\n  - {kind: crash, fraction: 0.1, between_s: [5, 20]}\n"
    )
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(
        "scenario: s.yaml\ngrid:\n"
        "  faults.0.fraction: [0.0, 0.5]\n  faults.0.kind: [crash, radio]\n"
    )
    plan = plan_sweep(sweep)
    assert len(plan.trials) == 4
    half = [t for t in plan.trials if dict(t.values)["faults.0.fraction"] == 0.5]
    assert {len(build_scenario(t).faults(t.seed)) for t in half} == {5}
    sweep.write_text("scenario: s.yaml\ngrid:\n  faults.0.fraction: [0.5, 2.0]\n")
    with pytest.raises(SweepError, match=r"faults\.0\.fraction"):
        plan_sweep(sweep)
