"""Each model family's kernels are private; its package exports the models only."""

import importlib

import pytest

FAMILIES = {
    "greyml.grey": ["AGO", "AccumulatedTargetRegressor", "GMC", "GNNMCI"],
    "greyml.fuzzy": ["ANFISFCM", "ANFISGrid"],
    "greyml.neural": ["MLPBaseline"],
}
#: The private modules holding each family's kernels.
KERNELS = {
    "greyml.grey": ["greyml.grey._kernels", "greyml.grey._response"],
    "greyml.fuzzy": ["greyml.fuzzy._kernels"],
    "greyml.neural": ["greyml.neural._kernels"],
}


@pytest.mark.parametrize("package", sorted(FAMILIES))
def test_the_package_exports_the_models_and_the_private_modules_the_kernels(package):
    pkg = importlib.import_module(package)
    assert set(FAMILIES[package]) == set(pkg.__all__)
    assert not hasattr(pkg, "kernels")  # no public kernels namespace
    for module_name in KERNELS[package]:
        kernels = importlib.import_module(module_name)
        # not both: no kernel in the package's own public names
        assert not set(kernels.__all__) & set(pkg.__all__)
        for name in kernels.__all__:
            value = getattr(kernels, name)
            assert callable(value) or name.isupper(), name  # constants: ACTIVATIONS, ...
