"""Our openpi wire format and image resizing against openpi-client itself (PyPI 0.1.2), the reference
the standard protocol must match (issue 75). openpi-client pins numpy<2, which this project's NumPy 2
cannot install beside, so its two modules are loaded from its wheel (read from the package registry
once, never installed): ``msgpack_numpy`` and ``image_tools`` need only msgpack, NumPy and Pillow."""

from __future__ import annotations

import importlib.util
import zipfile
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from libero_bench.rollouts.observations import resize_with_pad
from libero_bench.rollouts.wire import pack, unpack

WHEEL = "openpi_client-0.1.2-py3-none-any.whl"
SHA256 = "b8aa6d2ea7172d3b7c1fcf867d43930052b5ff19ea7b777966781105aa989897"


@pytest.fixture(scope="module")
def openpi(tmp_path_factory: pytest.TempPathFactory) -> dict[str, ModuleType]:
    from tests.conftest import registry_wheel

    wheel = registry_wheel("openpi-client==0.1.2", WHEEL, SHA256)
    folder = tmp_path_factory.mktemp("openpi_client")
    with zipfile.ZipFile(wheel) as z:
        z.extractall(folder)
    modules = {}
    for name in ("msgpack_numpy", "image_tools"):
        spec = importlib.util.spec_from_file_location(
            f"openpi_{name}", folder / "openpi_client" / f"{name}.py"
        )
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        modules[name] = module
    return modules


def _request(rng: np.random.Generator) -> dict[str, Any]:
    return {
        "observation/image": rng.integers(0, 256, (224, 224, 3), dtype=np.uint8),
        "observation/wrist_image": rng.integers(0, 256, (224, 224, 3), dtype=np.uint8),
        "observation/state": rng.normal(size=8),
        "prompt": "put both the alphabet soup and the tomato sauce in the basket",
        "step": np.int64(7),
        "nested": {"actions": rng.normal(size=(10, 7)).astype(np.float32), "ok": np.bool_(True)},
    }


def _equal(a: Any, b: Any) -> None:
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b)
        for k in a:
            _equal(a[k], b[k])
    elif isinstance(a, np.ndarray | np.generic):
        assert type(b) is type(a) and b.dtype == a.dtype
        np.testing.assert_array_equal(b, a)
    else:
        assert b == a and type(b) is type(a)


def test_our_messages_and_openpi_clients_read_each_other(openpi: dict[str, ModuleType]) -> None:
    theirs = openpi["msgpack_numpy"]
    message = _request(np.random.default_rng(0))
    _equal(message, theirs.unpackb(pack(message)))  # what we send, as openpi's server reads it
    _equal(message, unpack(theirs.packb(message)))  # what openpi's client sends, as we read it
    assert pack(message) == theirs.packb(message)  # byte for byte


@pytest.mark.parametrize("shape", [(256, 256), (200, 256), (256, 131), (224, 224), (64, 64), (17, 300)])
def test_images_are_resized_as_openpi_client_resizes_them(
    openpi: dict[str, ModuleType], shape: tuple[int, int]
) -> None:
    image = np.random.default_rng(1).integers(0, 256, size=(*shape, 3), dtype=np.uint8)
    np.testing.assert_array_equal(
        resize_with_pad(image, 224), openpi["image_tools"].resize_with_pad(image, 224, 224)
    )
