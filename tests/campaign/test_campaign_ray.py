"""The Ray engine runs the same chunks as the local engine and stores the same rows."""
from __future__ import annotations

import pytest

from crashscene.campaign import CampaignConfig, run_campaign
from tests.campaign import fakes
from tests.campaign.rows import table_rows

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray():
    """A small local Ray (2 CPUs, 100 MB object store), shut down after the test."""
    import ray.cloudpickle

    ray.cloudpickle.register_pickle_by_value(fakes)  # Ray workers cannot import the tests package
    ray.init(num_cpus=2, object_store_memory=100 * 1024 * 1024, include_dashboard=False, log_to_driver=False,
             logging_level="ERROR")
    yield
    ray.shutdown()
    ray.cloudpickle.unregister_pickle_by_value(fakes)


def _rows(out, table):
    return table_rows(out, table)


@pytest.mark.slow
def test_ray_engine_gives_the_same_rows_as_local(tmp_path, two_cases, local_ray):
    config = CampaignConfig(n=30, chunk_size=7, dsl_name="golden.yaml", seed=11)
    ray_summary = run_campaign(two_cases, tmp_path / "ray", config.model_copy(update={"engine": "ray", "workers": 2}),
                               worker=fakes.fake_chunk, quiet=True)
    local_summary = run_campaign(two_cases, tmp_path / "local", config.model_copy(update={"workers": 2}),
                                 worker=fakes.fake_chunk, quiet=True)
    assert ray_summary.engine == "ray" and ray_summary.complete and local_summary.complete
    assert ray_summary.chunks_run == local_summary.chunks_run == 2 * 2 * 5
    for table in ("variations", "violations", "collisions"):
        assert _rows(tmp_path / "ray", table) == _rows(tmp_path / "local", table)


@pytest.mark.slow
def test_ray_engine_matches_local_with_the_real_pipeline(tmp_path, two_cases, local_ray):
    config = CampaignConfig(n=4, chunk_size=2, dsl_name="golden.yaml", seed=3, modes=("test",))
    ray_summary = run_campaign(two_cases[:1], tmp_path / "ray", config.model_copy(update={"engine": "ray",
                                                                                          "workers": 2}), quiet=True)
    local_summary = run_campaign(two_cases[:1], tmp_path / "local", config.model_copy(update={"workers": 1}),
                                 quiet=True)
    assert ray_summary.complete and local_summary.complete, (ray_summary, local_summary)
    for table in ("variations", "violations", "collisions"):
        assert _rows(tmp_path / "ray", table) == _rows(tmp_path / "local", table)
    assert len(_rows(tmp_path / "ray", "variations")) == 4
