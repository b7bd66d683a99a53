"""The `carla` backend's error paths and helpers (crashscene.simulate.carla); no CARLA server is needed.

Where a test needs `import carla` to succeed it installs a stand-in module in
`sys.modules`; nothing here connects to a real server.
"""
from __future__ import annotations

import socket
import sys
import types
from pathlib import Path

import pytest

from crashscene.dsl import load_file
from crashscene.simulate import carla as carla_backend
from crashscene.simulate.backend import (
    BackendUnavailable,
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    create_simulator,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "ciren"
CASE = EXAMPLES / "100343" / "golden.yaml"
PROGRAM = "ego = new Car at (0, 0)\n"


@pytest.fixture
def scenario():
    return load_file(CASE)


@pytest.fixture
def closed_port() -> int:
    """A local TCP port nobody listens on."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture
def no_carla(monkeypatch):
    monkeypatch.setitem(sys.modules, "carla", None)  # `import carla` raises ImportError


@pytest.fixture
def fake_carla(monkeypatch):
    monkeypatch.setitem(sys.modules, "carla", types.ModuleType("carla"))


def request(scenario, tmp_path, program=PROGRAM):
    return SimulationRequest(scenario=scenario, scenes=[], map_file=tmp_path / "map.xodr", program=program)


def test_registered_under_its_name():
    assert isinstance(create_simulator("carla"), carla_backend.CarlaSimulator)


def test_without_the_client_says_what_to_install(no_carla, scenario, tmp_path):
    with pytest.raises(BackendUnavailable, match=r"pip install carla==0\.9\.16.*--backend embedded\|newtonian"):
        create_simulator("carla").simulate(request(scenario, tmp_path))


def test_without_a_server_names_host_and_port(fake_carla, scenario, tmp_path, closed_port):
    settings = SimulationSettings(carla_host="127.0.0.1", carla_port=closed_port)
    with pytest.raises(BackendUnavailable, match=rf"no CARLA server reachable at 127\.0\.0\.1:{closed_port}"):
        create_simulator("carla", settings).simulate(request(scenario, tmp_path))


def test_a_listening_port_passes_the_server_probe(closed_port):
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        carla_backend.check_server("127.0.0.1", server.getsockname()[1])  # no error


def test_missing_program_is_a_clear_error(scenario, tmp_path):
    with pytest.raises(SimulationError, match="needs the rendered Scenic program"):
        create_simulator("carla").simulate(request(scenario, tmp_path, program=None))


def test_unknown_ego_role_is_refused_before_connecting(no_carla, scenario, tmp_path):
    with pytest.raises(SimulationError, match="--ego 'npc7': no such actor"):
        create_simulator("carla", SimulationSettings(ego_role="npc7")).simulate(request(scenario, tmp_path))


def test_ads_only_in_test_mode(scenario, tmp_path):
    settings = SimulationSettings(mode="reproduce", ads=f"{__name__}:GoodAgent")
    with pytest.raises(SimulationError, match="test mode only"):
        create_simulator("carla", settings).simulate(request(scenario, tmp_path))


def test_bad_ads_is_refused_before_connecting(no_carla, scenario, tmp_path):
    settings = SimulationSettings(ads="no_such_package.stack:Agent")
    with pytest.raises(SimulationError, match="cannot import module 'no_such_package.stack'"):
        create_simulator("carla", settings).simulate(request(scenario, tmp_path))


class GoodAgent:
    def __init__(self, gain: float = 1.0):
        self.gain = gain

    def setup(self, world, ego, actor, map_file, dt):
        pass

    def run_step(self, t):
        return None

    def teardown(self):
        pass


class NotAnAgent:
    def run_step(self, t):
        return None


@pytest.mark.parametrize("spec, message", [
    ("nocolon", "expected 'package.module:Class'"),
    (f"{__name__}:Missing", "has no class 'Missing'"),
    (f"{__name__}:NotAnAgent", "needs methods setup, run_step and teardown"),
])
def test_load_agent_errors(spec, message):
    with pytest.raises(SimulationError, match=message):
        carla_backend.load_agent(spec)


def test_load_agent_passes_parameters():
    agent = carla_backend.load_agent(f"{__name__}:GoodAgent", {"gain": 2.5})
    assert isinstance(agent, GoodAgent) and agent.gain == 2.5
    with pytest.raises(SimulationError, match="cannot create it with parameters"):
        carla_backend.load_agent(f"{__name__}:GoodAgent", {"nope": 1})


@pytest.mark.parametrize("name, town", [
    ("Town04.xodr", "Town04"), ("Town10HD.xodr", "Town10HD"), ("Town10HD_Opt.xodr", "Town10HD_Opt"),
    ("map.xodr", None), ("town04.xodr", None), ("Town4.xodr", None),
])
def test_carla_town_from_map_name(name, town):
    assert carla_backend.carla_town(Path("/x") / name) == town


def test_carla_town_from_the_program_wins():
    program = "param map = localPath('map.xodr')\nparam carla_map = 'Town05'\nmodel scenic.simulators.carla.model\n"
    assert carla_backend.carla_town(Path("/run/map.xodr"), program) == "Town05"
    assert carla_backend.carla_town(Path("/run/map.xodr"), "param carla_map = 'os.system'\n") is None


@pytest.mark.slow
def test_program_compiles_under_the_carla_model_without_a_client(no_carla, tmp_path):
    # Scenic's CARLA model compiles and samples without `carla`: only the run needs it.
    from scenariogeneration import xodr

    from crashscene.simulate.newtonian import compile_program

    odr = xodr.OpenDrive("straight")
    odr.add_road(xodr.create_road(xodr.Line(200), id=1, left_lanes=1, right_lanes=1, lane_width=3.5))
    odr.adjust_roads_and_lanes()
    odr.write_xml(str(tmp_path / "map.xodr"))
    program = "model scenic.domains.driving.model\nego = new Car on road\n"
    scenario = compile_program(program, tmp_path / "map.xodr", model=carla_backend.CARLA_MODEL,
                               extra_params={"render": 0, "carla_map": None})
    scene, _ = scenario.generate(maxIterations=100)
    assert len(scene.objects) == 1


@pytest.fixture
def mock_carla(monkeypatch):
    """`import carla` gives a MagicMock; Scenic's CARLA interface modules imported under it are dropped after."""
    from unittest.mock import MagicMock

    before = {name for name in sys.modules if name.startswith("scenic.simulators.carla")}
    module = MagicMock(name="carla")
    monkeypatch.setitem(sys.modules, "carla", module)
    yield module
    for name in [n for n in sys.modules if n.startswith("scenic.simulators.carla") and n not in before]:
        del sys.modules[name]


def test_scenic_carla_subclasses_build_and_hook_in(mock_carla, tmp_path):
    simulator_class = carla_backend._tracing_classes(mock_carla)
    from scenic.simulators.carla.simulator import CarlaSimulator

    assert issubclass(simulator_class, CarlaSimulator)
    xodr = tmp_path / "map.xodr"
    xodr.write_text("<OpenDRIVE/>")
    simulator = simulator_class(None, str(xodr), address="10.0.0.5", port=2010, render=False, timestep=0.1)
    mock_carla.Client.assert_called_with("10.0.0.5", 2010)
    simulator.client.generate_opendrive_world.assert_called_once_with("<OpenDRIVE/>")  # no town: from the file
    simulator_class("Town04", str(xodr), address="10.0.0.5", port=2010, render=False, timestep=0.1)
    mock_carla.Client.return_value.load_world.assert_called_with("Town04")
    simulator.prepare([(0.0, 0.0, 0.0, 5.0)], agent_index=None)
    assert simulator.pins == [(0.0, 0.0, 0.0, 5.0)] and simulator.agent is None


def test_basic_agent_adapter_drives_towards_a_destination_ahead(monkeypatch):
    from unittest.mock import MagicMock

    basic_agent = MagicMock(name="BasicAgent")
    navigation = types.ModuleType("agents.navigation.basic_agent")
    navigation.BasicAgent = basic_agent
    for name, module in {"agents": types.ModuleType("agents"), "agents.navigation": types.ModuleType("x"),
                         "agents.navigation.basic_agent": navigation}.items():
        monkeypatch.setitem(sys.modules, name, module)
    agent = carla_backend.load_agent("crashscene.simulate.carla:CarlaBasicAgent", {"horizon": 150.0})
    world, ego = MagicMock(name="world"), MagicMock(name="ego")
    actor = carla_backend.SampledActor(role="ego", type="car", blueprint="vehicle.tesla.model3", behavior="go_forward",
                                       x=0, y=0, yaw=0, speed=10.0, length=4.7, width=2.0, route_intent="straight",
                                       reference="road", relation="behind")
    agent.setup(world, ego, actor, Path("map.xodr"), 0.1)
    basic_agent.assert_called_once_with(ego, target_speed=36.0)  # km/h
    world.get_map.return_value.get_waypoint.return_value.next.assert_called_once_with(150.0)
    assert agent.run_step(0.1) is basic_agent.return_value.run_step.return_value
    agent.teardown()


def test_basic_agent_without_the_python_api_says_where_to_find_it(monkeypatch):
    from unittest.mock import MagicMock

    monkeypatch.setitem(sys.modules, "agents", None)
    agent = carla_backend.CarlaBasicAgent()
    with pytest.raises(BackendUnavailable, match="PythonAPI/carla to PYTHONPATH"):
        agent.setup(MagicMock(), MagicMock(), MagicMock(speed=5.0), Path("map.xodr"), 0.1)
