"""Hypothesis over the configuration and calibration structure: any mutation of a valid file is
accepted or refused with one ConfigError line naming the file and the key, never another exception.

The mutations (lab.faults._fuzz: wrong types, missing and extra keys, out-of-range and non-finite
numbers, nesting, nulls, non-string keys) are driven by hypothesis' `randoms()`, so a failure shrinks
to one small mutation; the validating functions are the daemon's own, called in-process on the parsed
mapping for speed (tests/faults/test_inputs.py runs files and real subprocesses).
"""

from __future__ import annotations

import random
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lab.faults import _fuzz as fuzz
from lab.faults.inputs import FuzzBase, check_bytes, check_mapping, fuzz_bases

BASES = fuzz_bases(Path(tempfile.mkdtemp(prefix="fuzz-")))


@pytest.mark.parametrize("base", BASES, ids=lambda b: b.name)
def test_the_valid_examples_are_accepted(base: FuzzBase) -> None:
    assert check_mapping(base, base.valid).accepted


@pytest.mark.parametrize("base", BASES, ids=lambda b: b.name)
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rng=st.randoms(use_true_random=False), extra=st.integers(0, 2))
def test_any_mutation_is_accepted_or_one_line_naming_file_and_key(base: FuzzBase, rng: random.Random,
                                                                  extra: int) -> None:
    data, what = fuzz.mutate(base.valid, rng)
    for _ in range(extra):  # two or three mistakes at once: the first one found is reported
        data, what = fuzz.mutate(data, rng)[0], what + " and more"
    verdict = check_mapping(base, data)
    assert verdict.ok, f"{what}: {verdict.text}"


@pytest.mark.parametrize("base", BASES, ids=lambda b: b.name)
@settings(max_examples=15, deadline=None)
@given(rng=st.randoms(use_true_random=False))
def test_hostile_files_are_accepted_or_one_line_naming_the_file(base: FuzzBase,
                                                                       rng: random.Random) -> None:
    verdict = check_bytes(base, fuzz.hostile_bytes(rng, yaml.safe_dump(base.valid).encode()))
    assert verdict.ok, verdict.text  # a BOM or a cut at a line end can leave a valid file


def test_the_mutator_reaches_every_key() -> None:
    base = BASES[0]
    rng, touched = random.Random(0), set()
    for _ in range(400):
        touched.add(fuzz.mutate(base.valid, rng)[1].split(" at ")[1].split(".")[0].split(" ")[0])
    assert set(base.valid) <= touched
