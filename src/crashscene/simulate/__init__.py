"""Simulate stage: run sampled scenes on a backend (embedded batched numpy by default) and write traces.

Public entry point: the backend interface in `crashscene.simulate.backend`. The orchestrator that
renders, samples, simulates and monitors one scenario, `simulate_scenario`, sits above the stages in
`crashscene.pipeline.simulate`.
"""
from crashscene.simulate.backend import (
    AdsError,
    BackendUnavailable,
    BatchResult,
    SceneResult,
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    Simulator,
    backend_names,
    backend_target,
    create_simulator,
    get_simulator_class,
    register_backend,
)

__all__ = ["AdsError", "BackendUnavailable", "BatchResult", "SceneResult", "SimulationError", "SimulationRequest",
           "SimulationSettings", "Simulator", "backend_names", "backend_target", "create_simulator",
           "get_simulator_class", "register_backend"]
