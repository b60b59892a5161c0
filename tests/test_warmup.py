"""The kernel warm-up: every method compiled exactly once, families kept together."""

from __future__ import annotations

import pytest

from sideslip.methods.registry import all_methods
from sideslip.warmup import FAMILIES, OTHER_METHOD_S, main, method_groups, warm_group


@pytest.mark.parametrize("jobs", [1, 2, 3, 8])
def test_every_method_is_warmed_once_and_no_family_is_split(jobs):
    groups = method_groups(jobs)
    flat = [n for g in groups for n in g]
    assert sorted(flat) == sorted(all_methods())
    assert len(groups) <= jobs
    where = {n: i for i, g in enumerate(groups) for n in g}
    for family, _ in FAMILIES:
        present = [n for n in family if n in where]
        assert len({where[n] for n in present}) <= 1, family


def test_two_processes_share_the_compile_time_within_the_largest_family():
    """Longest-first dealing: the two loads differ by at most the largest family's seconds
    (the fused engine's, which alone is most of one process)."""
    cost = {n: s for fam, s in FAMILIES for n in fam[:1]}
    groups = method_groups(2)
    loads = [
        sum(cost.get(n, 0.0 if any(n in f for f, _ in FAMILIES) else OTHER_METHOD_S) for n in g)
        for g in groups
    ]
    assert len(groups) == 2
    assert abs(loads[0] - loads[1]) <= max(s for _, s in FAMILIES)
    assert "fused" in groups[0] and "ekf_wss_sas" in groups[1]


def test_a_group_runs_its_methods_on_the_warm_drive():
    assert warm_group(["kinematic_integration", "obs_bicycle"]) > 0.0


def test_jobs_below_one_is_refused_with_the_expectation(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--jobs", "0"])
    assert exit_info.value.code == 2
    assert "--jobs 0: expected an integer >= 1" in capsys.readouterr().err
