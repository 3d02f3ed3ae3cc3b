"""``greyml fit`` on a folder or a glob of files: read piece by piece, the model of the
rows read whole."""

import numpy as np
import pytest
from _recordings import tiled

from greyml import ThermalTransferFunction
from greyml.cli import main
from greyml.persist import load_model


@pytest.fixture(scope="module")
def recording():
    X, y = tiled(4, hours=16.0)
    return X, y, ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)


def test_a_folder_of_parquet_files_gives_the_model_of_all_rows(recording, tmp_path, capsys):
    pytest.importorskip("pyarrow")
    X, y, whole = recording
    folder = tmp_path / "logs"
    folder.mkdir()
    flat = X.reset_index().assign(dx_um=y)
    flat.iloc[:500].to_parquet(folder / "a.parquet")
    flat.iloc[500:].to_parquet(folder / "b.parquet")
    out = tmp_path / "m.greyml"
    argv = ["fit", str(folder), "--target", "dx_um", "--model", "transfer-function"]
    assert main([*argv, "--drivers", "spindle_rpm", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "4 tests in 2 files" in printed
    assert "no scores on the training rows" in printed
    model = load_model(out)
    np.testing.assert_array_equal(model.feature_coef_, whole.feature_coef_)
    assert model.selected_sensors_ == whole.selected_sensors_


def test_a_glob_of_csv_files_one_test_each(recording, tmp_path):
    X, y, whole = recording
    flat = X.reset_index().assign(dx_um=y)
    for label, part in flat.groupby("test", sort=False):
        part.drop(columns="test").to_csv(tmp_path / f"{label}.csv", index=False)
    out = tmp_path / "m.greyml"
    argv = ["fit", str(tmp_path / "r*.csv"), "--target", "dx_um", "--model", "transfer-function"]
    assert main([*argv, "--drivers", "spindle_rpm", "--out", str(out), "--quiet"]) == 0
    np.testing.assert_array_equal(load_model(out).feature_coef_, whole.feature_coef_)


def test_many_files_for_another_model_is_one_line(recording, tmp_path, capsys):
    X, y, _ = recording
    X.reset_index().assign(dx_um=y).to_csv(tmp_path / "a.csv", index=False)
    out = tmp_path / "m.greyml"
    code = main(["fit", str(tmp_path), "--target", "dx_um", "--model", "gmc", "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err
    assert "only --model transfer-function reads files piece by piece" in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()
