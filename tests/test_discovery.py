"""greyml.utils.discovery.all_estimators: every estimator greyml defines."""

import inspect

import pytest
from sklearn.base import BaseEstimator, RegressorMixin, TransformerMixin

import greyml
from greyml import Compensator, LagFeatures, ThermalTransferFunction
from greyml.utils.discovery import all_estimators


def test_every_public_estimator_is_found_once_and_sorted():
    found = all_estimators()
    names = [name for name, _ in found]
    assert names == sorted(names) and len(set(names)) == len(names)
    # the estimators exported at the top level: each is one greyml defines
    public = {
        name: obj
        for name in greyml.__all__
        if inspect.isclass(obj := getattr(greyml, name)) and issubclass(obj, BaseEstimator)
    }
    assert dict(found) == public
    assert {"GMC", "ANFISFCM", "MLPBaseline", "GreyInfluenceSelector"} <= set(names)


def test_the_dynamic_estimators_are_found():
    found = dict(all_estimators())
    assert found["LagFeatures"] is LagFeatures
    assert found["ThermalTransferFunction"] is ThermalTransferFunction
    # the compensator is a runtime object a controller runs, not an estimator
    assert "Compensator" not in found and not hasattr(Compensator, "fit")


def test_only_greyml_estimators_not_splitters_or_private_bases():
    for name, cls in all_estimators():
        assert cls.__module__.startswith("greyml.") and not name.startswith("_")
    names = {name for name, _ in all_estimators()}
    # a splitter and the optimisers are not estimators; scikit-learn's are not greyml's
    assert not names & {"TrainOnOneTest", "ParticleSwarm", "CuckooSearch", "Ridge", "Pipeline"}
    assert not names & {"_ANFISBase", "_GreyConvolutionModel"}


@pytest.mark.parametrize(
    ("type_filter", "mixin"), [("regressor", RegressorMixin), ("transformer", TransformerMixin)]
)
def test_type_filter(type_filter, mixin):
    every = all_estimators()
    kept = all_estimators(type_filter=type_filter)
    assert kept == [(n, c) for n, c in every if issubclass(c, mixin)]
    assert kept and len(kept) < len(every)
    assert all_estimators(type_filter=[type_filter]) == kept


def test_type_filters_combined_and_of_no_greyml_kind():
    both = all_estimators(type_filter=["regressor", "transformer"])
    assert [name for name, _ in both] == [name for name, _ in all_estimators()]
    assert all_estimators(type_filter="classifier") == []


@pytest.mark.parametrize("type_filter", ["regresor", ["regressor", "sensor"], []])
def test_an_unknown_type_filter_is_refused(type_filter):
    with pytest.raises(ValueError, match="type_filter must be 'regressor', 'transformer'"):
        all_estimators(type_filter=type_filter)
