"""Output names: the stem alone where it is unique, parent folders only where two drives clash."""

from __future__ import annotations

from sideslip.batch.naming import output_keys


def test_unique_stems_keep_their_plain_names() -> None:
    keys = output_keys(["/data/a/one.parquet", "/data/b/two.csv"])
    assert keys == {"/data/a/one.parquet": "one", "/data/b/two.csv": "two"}


def test_clashing_stems_take_just_enough_parent_folders() -> None:
    drives = ["/fleet/car1/mon/drive.parquet", "/fleet/car1/tue/drive.parquet",
              "/fleet/car2/mon/drive.parquet", "/other/x.parquet"]
    keys = output_keys(drives)
    assert keys["/other/x.parquet"] == "x"
    assert keys["/fleet/car1/tue/drive.parquet"] == "tue/drive"
    assert keys["/fleet/car1/mon/drive.parquet"] == "car1/mon/drive"
    assert keys["/fleet/car2/mon/drive.parquet"] == "car2/mon/drive"
    assert len(set(keys.values())) == len(drives)


def test_same_folder_different_extension_and_urls_and_duplicates() -> None:
    keys = output_keys(["/d/run.csv", "/d/run.parquet", "s3://bucket/d/run.parquet", "/d/run.csv"])
    assert len(keys) == 3 and len(set(keys.values())) == 3
    assert keys["/d/run.csv"].endswith("run_csv") and keys["/d/run.parquet"].endswith("run_parquet")
    assert keys["s3://bucket/d/run.parquet"].endswith("run") and "bucket" in keys["s3://bucket/d/run.parquet"]
