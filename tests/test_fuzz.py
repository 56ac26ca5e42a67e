"""A CI-sized fuzz run of every reader (issue 16): mutated files give a clean DenavitError or are accepted
(with the same numbers where the mutation cannot change the meaning); never another exception or a hang.
The long run: ``python benchmarks/fuzz_readers.py --cases 3000``."""

import pytest
from fuzzing import campaign, seeds


@pytest.mark.parametrize("reader", sorted(seeds()))
def test_mutated_files_keep_the_contract(reader):
    counts = campaign(200, seed=11, readers={reader})[reader]
    assert counts["other exceptions"] == 0 and counts["hangs"] == 0, counts["failures"][:5]
    assert counts["cases"] == 200
