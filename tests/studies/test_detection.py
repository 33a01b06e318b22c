from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd

from bayescal.studies.detection import detection_power, markdown_table, power_threshold

DATA = Path(__file__).resolve().parents[2] / "data"


def test_detection_table_does_not_depend_on_the_number_of_workers():
    arguments = (DATA / "kr270.toml", DATA / "table3_plan.csv", {"backlash": [0.015]})
    options = {"n_seeds": 1, "n_null": 1, "seed": 3}
    with ThreadPoolExecutor(1) as one, ThreadPoolExecutor(2) as two:
        a = detection_power(*arguments, executor=one, **options)
        b = detection_power(*arguments, executor=two, **options)
    pd.testing.assert_frame_equal(a, b)
    assert a["effect"].tolist() == ["none", "backlash"]
    assert a.loc[1, "found_first"] == 1.0 and a.loc[0, "misfit"] == 0.0
    assert power_threshold(a) == {"backlash": 0.015}
    assert "| backlash | 0.015 | deg | 1 | 100 % |" in markdown_table(a)
