"""The lab: what measures and tortures the appliance but never ships on a mast.

Evaluation against ground truth (`lab.evaluate`), benchmarks (`lab.bench`), fault injection and the
soak (`lab.faults`) and fake devices (`lab.fakes`). Tests and tools/ import it from the checkout;
the wheel, `tools/bundle` and `tools/install` leave it out (tests/test_house.py checks the wheel).
"""
