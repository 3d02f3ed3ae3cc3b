"""Each model family's kernels live in one documented namespace; old imports warn."""

import importlib

import pytest

FAMILIES = {
    "greyml.grey": ["AGO", "AccumulatedTargetRegressor", "GMC", "GNNMCI", "fit_gm1n"],
    "greyml.fuzzy": ["ANFISFCM", "ANFISGrid"],
    "greyml.neural": ["MLPBaseline"],
}


@pytest.mark.parametrize("package", sorted(FAMILIES))
def test_kernels_namespace_holds_the_kernels_and_the_package_the_models(package):
    pkg = importlib.import_module(package)
    kernels = importlib.import_module(f"{package}.kernels")
    assert set(FAMILIES[package]) <= set(pkg.__all__)
    # not both: no kernel in the package's own public names
    assert not set(kernels.__all__) & set(pkg.__all__)
    for name in kernels.__all__:
        assert callable(getattr(kernels, name)) or name == "ACTIVATIONS", name


@pytest.mark.parametrize("package", sorted(FAMILIES))
def test_old_kernel_imports_warn_and_give_the_same_object(package):
    pkg = importlib.import_module(package)
    kernels = importlib.import_module(f"{package}.kernels")
    name = kernels.__all__[0]
    with pytest.warns(FutureWarning, match=rf"{package}\.{name} moved to {package}\.kernels"):
        old = getattr(pkg, name)
    assert old is getattr(kernels, name)
    with pytest.raises(AttributeError, match="has no attribute 'not_a_kernel'"):
        pkg.not_a_kernel  # noqa: B018
