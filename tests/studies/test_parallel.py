from concurrent.futures import ThreadPoolExecutor

import numpy as np

from bayescal.studies.parallel import seeded_map


def noisy_sum(item: int, rng: np.random.Generator, *, scale: float) -> float:
    return item + scale * float(rng.normal())


def test_results_depend_on_the_seed_only_not_on_the_workers():
    serial = seeded_map(noisy_sum, range(6), 7, executor=ThreadPoolExecutor(max_workers=1), scale=0.5)
    parallel = seeded_map(noisy_sum, range(6), 7, executor=ThreadPoolExecutor(max_workers=3), scale=0.5)
    pooled = seeded_map(noisy_sum, range(6), 7, scale=0.5)
    assert serial == parallel == pooled
    assert seeded_map(noisy_sum, range(6), 8, executor=ThreadPoolExecutor(), scale=0.5) != serial


def test_each_item_gets_its_own_stream_in_order():
    draws = seeded_map(noisy_sum, [0, 0, 0], 1, executor=ThreadPoolExecutor(), scale=1.0)
    assert len(set(draws)) == 3
    first_two = seeded_map(noisy_sum, [0, 0], 1, executor=ThreadPoolExecutor(), scale=1.0)
    assert first_two == draws[:2]
