"""The bench's own machinery: the networks it generates are kept in the cache folder."""

import subprocess

import pytest

from enn_traffic import bench


def test_a_generated_network_is_made_once_and_a_failed_one_leaves_nothing(tmp_path,
                                                                          monkeypatch):
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path))
    made = []

    def make(folder):
        made.append(folder)
        (folder / "city.net.xml").write_text("<net/>")

    first = bench._generated("city", make)
    assert bench._generated("city", make) == first and len(made) == 1
    assert (first / "city.net.xml").read_text() == "<net/>"

    def broken(folder):
        (folder / "half.net.xml").write_text("<net")
        raise subprocess.CalledProcessError(1, "netgenerate")

    with pytest.raises(subprocess.CalledProcessError):
        bench._generated("broken", broken)
    assert sorted(path.name for path in first.parent.iterdir()) == ["city"]
