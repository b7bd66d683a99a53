"""The openai backend against a scripted OpenAI-compatible server on 127.0.0.1, through the real SDK.

Covers: structured parse with the strict schema, the sketch as an image part,
a reply that fails validation then a good one (re-ask loop), a reply that is
not JSON, the review-and-revise pass, a 429 then success, a timeout then
success, 5xx exhausting the retries (clear error, and a batch goes on), a 401
failing at once, and a missing API key. No network.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from PIL import Image

from crashscene.dsl import load_file
from crashscene.extract.llm_schema import from_scenario
from crashscene.extract.openai_backend import BackendError, ChatBackend, RetryPolicy, Usage, price_for
from crashscene.extract.pipeline import ExtractOptions, extract_batch, extract_case
from tests.extract.fake_openai import FakeOpenAI, error, reply, stall

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "ciren"
FAST = RetryPolicy(max_retries=2, base_delay=0.01, max_delay=0.05)


def golden_reply(case: str) -> dict:
    return from_scenario(load_file(EXAMPLES / case / "golden.yaml")).model_dump(mode="json")


@pytest.fixture
def case_dir(tmp_path: Path) -> Path:
    """A real narrative with a small sketch image (blank: OCR finds nothing, quickly)."""
    folder = tmp_path / "100237"
    folder.mkdir()
    (folder / "narrative.txt").write_text((EXAMPLES / "100237" / "narrative.txt").read_text())
    Image.new("RGB", (64, 48), "white").save(folder / "sketch.png")
    return folder


def options(server: FakeOpenAI, **kwargs) -> ExtractOptions:
    base = dict(backend="openai", base_url=server.base_url, retry=FAST, timeout=5.0, revise=False)
    base.update(kwargs)
    return ExtractOptions(**base)


def test_structured_parse_and_usage(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test")
    with FakeOpenAI([reply(golden_reply("100237"), prompt_tokens=1200, completion_tokens=300,
                                  cached_tokens=1000)]) as server:
        backend = ChatBackend(base_url=server.base_url, retry=FAST)
        completion = backend.complete([{"role": "user", "content": "report"}])
        request = server.requests[0]
    assert completion.parsed is not None and completion.invalid is None
    assert completion.parsed.road_network.road_type.value == "intersection"
    assert request["model"] == "gpt-4o-mini"
    fmt = request["response_format"]
    assert fmt["type"] == "json_schema" and fmt["json_schema"]["strict"] is True
    assert fmt["json_schema"]["schema"]["additionalProperties"] is False
    assert completion.usage == Usage(prompt_tokens=1200, cached_tokens=1000, completion_tokens=300, requests=1)
    inp, cached, out = price_for("gpt-4o-mini")
    assert backend.cost(completion.usage) == pytest.approx((200 * inp + 1000 * cached + 300 * out) / 1e6)


def test_sketch_goes_as_an_image_part(case_dir: Path) -> None:
    with FakeOpenAI([reply(golden_reply("100237"))]) as server:
        result = extract_case(case_dir, options=options(server))
        user = server.requests[0]["messages"][-1]
    parts = user["content"]
    assert isinstance(parts, list)
    images = [p for p in parts if p["type"] == "image_url"]
    assert len(images) == 1 and images[0]["image_url"]["url"].startswith("data:image/png;base64,")
    assert "traveling east in the eastbound lane" in parts[0]["text"]
    assert result.status == "ok" and result.backend == "openai" and result.tokens.requests == 1
    assert result.scenario.actors["npc1"].position.reference == "yield_sign"
    assert result.cost_usd is not None and result.cost_usd > 0


def test_invalid_reply_is_fed_back_then_fixed(case_dir: Path) -> None:
    bad = golden_reply("100237")
    bad["road_network"]["traffic_signs"] = ["speed_limit_sign"]  # npc1 references a yield_sign not listed
    with FakeOpenAI([reply(bad), reply(golden_reply("100237"))]) as server:
        result = extract_case(case_dir, options=options(server))
        second = server.requests[1]["messages"]
    assert len(server.requests) == 2
    feedback = second[-1]["content"]
    assert "actors.npc1.position.reference" in feedback and "yield_sign" in feedback
    assert second[-2]["role"] == "assistant"
    assert result.scenario.road_network.traffic_signs == ["yield_sign", "speed_limit_sign"]
    assert result.tokens.requests == 2


def test_reply_that_is_not_json_is_reasked(case_dir: Path) -> None:
    with FakeOpenAI([reply("Sure! Here is the scenario: ..."), reply(golden_reply("100237"))]) as server:
        result = extract_case(case_dir, options=options(server))
        feedback = server.requests[1]["messages"][-1]["content"]
    assert "does not fit the schema" in feedback
    assert result.status == "ok"


def test_cut_off_reply_is_reasked_with_a_hint(case_dir: Path) -> None:
    with FakeOpenAI([reply('{"summary": "V1 V1 V1', finish_reason="length"), reply(golden_reply("100237"))]) as server:
        result = extract_case(case_dir, options=options(server))
        feedback = server.requests[1]["messages"][-1]["content"]
    assert "cut off at the limit of 2048 tokens" in feedback and result.status == "ok"


def test_no_valid_reply_within_budget_is_a_clear_error(case_dir: Path) -> None:
    from crashscene.extract.revise import LlmOutputError

    with FakeOpenAI([reply("{}")] * 3) as server:
        with pytest.raises(LlmOutputError, match="no valid scenario in 2 replies"):
            extract_case(case_dir, options=options(server, max_reasks=1))


def test_review_finding_triggers_one_revision(case_dir: Path) -> None:
    rainy = golden_reply("100237")
    rainy["environment"]["weather"] = "rainy"  # the report says cloudy
    with FakeOpenAI([reply(rainy), reply(golden_reply("100237"))]) as server:
        result = extract_case(case_dir, options=options(server, revise=True))
        remarks = server.requests[1]["messages"][-1]["content"]
    assert "environment.weather: rainy is not mentioned" in remarks
    assert result.scenario.environment.weather == "cloudy"
    assert result.tokens.requests == 2


def test_revision_failure_keeps_the_valid_draft(case_dir: Path) -> None:
    rainy = golden_reply("100237")
    rainy["environment"]["weather"] = "rainy"
    with FakeOpenAI([reply(rainy)] + [error(500)] * 3) as server:
        result = extract_case(case_dir, options=options(server, revise=True))
    assert result.status == "ok" and result.scenario.environment.weather == "rainy"
    assert any("not revised" in w for w in result.warnings)
    assert any("environment.weather" in w for w in result.warnings)


def test_failed_case_reports_its_tokens(case_dir: Path, tmp_path: Path) -> None:
    with FakeOpenAI([reply("{}", prompt_tokens=500, completion_tokens=5)] * 2) as server:
        results = extract_batch([case_dir], tmp_path / "out", options=options(server, max_reasks=1))
    assert results[0].status == "error" and results[0].tokens.total == 1010 and results[0].cost_usd > 0


def test_429_then_success_waits_retry_after() -> None:
    waits: list[float] = []
    with FakeOpenAI([error(429, {"retry-after": "0.02"}), reply(golden_reply("103378"))]) as server:
        backend = ChatBackend(base_url=server.base_url, retry=FAST, sleep=waits.append)
        completion = backend.complete([{"role": "user", "content": "report"}])
    assert completion.parsed is not None
    assert len(server.requests) == 2 and waits == [0.02]


def test_timeout_then_success() -> None:
    waits: list[float] = []
    with FakeOpenAI([stall(1.5), reply(golden_reply("103378"))]) as server:
        backend = ChatBackend(base_url=server.base_url, retry=FAST, timeout=0.3, sleep=waits.append)
        completion = backend.complete([{"role": "user", "content": "report"}])
    assert completion.parsed is not None and waits == [0.01]


def test_5xx_exhausts_retries_with_a_clear_error() -> None:
    waits: list[float] = []
    with FakeOpenAI([error(503)] * 3) as server:
        backend = ChatBackend(base_url=server.base_url, retry=FAST, sleep=waits.append)
        with pytest.raises(BackendError) as caught:
            backend.complete([{"role": "user", "content": "report"}])
    message = str(caught.value)
    assert "still failing after 3 attempts" in message and server.base_url in message and "503" in message
    assert waits == [0.01, 0.02]  # deterministic exponential backoff


def test_batch_goes_on_after_a_case_fails(case_dir: Path, tmp_path: Path) -> None:
    other = tmp_path / "103378"
    other.mkdir()
    (other / "narrative.txt").write_text((EXAMPLES / "103378" / "narrative.txt").read_text())
    out = tmp_path / "out"
    with FakeOpenAI([error(500)] * 3 + [reply(golden_reply("103378"))]) as server:
        results = extract_batch([case_dir, other], out, options=options(server))
    assert [r.status for r in results] == ["error", "ok"]
    assert "still failing after 3 attempts" in results[0].error
    assert results[0].tokens.total == 0 and results[1].tokens.requests == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ok"] == 1 and summary["failed"] == 1
    assert [row["status"] for row in summary["results"]] == ["error", "ok"]
    assert {"tokens", "cost_usd", "seconds", "case_id", "error"} <= set(summary["results"][0])
    assert not (out / "100237.yaml").exists() and (out / "103378.yaml").is_file()


def test_client_error_fails_at_once() -> None:
    with FakeOpenAI([error(401), reply(golden_reply("103378"))]) as server:
        backend = ChatBackend(base_url=server.base_url, retry=FAST)
        with pytest.raises(BackendError, match="HTTP 401"):
            backend.complete([{"role": "user", "content": "report"}])
        assert len(server.requests) == 1


def test_missing_api_key_is_explained(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    with pytest.raises(BackendError, match="OPENAI_API_KEY"):
        ChatBackend().client


def test_price_table() -> None:
    assert price_for("gpt-4o-mini-2024-07-18") == price_for("gpt-4o-mini")
    assert price_for("llama3:8b") is None
    assert ChatBackend(model="llama3:8b").cost(Usage(prompt_tokens=10)) is None
    inp, cached, out = price_for("gpt-4o-mini")
    usage = Usage(prompt_tokens=1000, cached_tokens=600, completion_tokens=100)
    assert ChatBackend().cost(usage) == pytest.approx((400 * inp + 600 * cached + 100 * out) / 1e6)


def test_review_checks_the_oracle_by_convention_9_and_revision_restores_it(tmp_path: Path) -> None:
    folder = tmp_path / "121520"  # V1 turned left across the oncoming V2 (CVC_21801)
    folder.mkdir()
    (folder / "narrative.txt").write_text((EXAMPLES / "121520" / "narrative.txt").read_text())
    Image.new("RGB", (64, 48), "white").save(folder / "sketch.png")
    draft = golden_reply("121520")
    draft["oracle"] = [entry for entry in draft["oracle"] if entry["code"] != "CVC_21801"]
    with FakeOpenAI([reply(draft), reply(golden_reply("121520"))]) as server:
        result = extract_case(folder, options=options(server, revise=True))
        remarks = server.requests[1]["messages"][-1]["content"]
    assert "CVC_21801 left_turn_yield is missing" in remarks
    assert "CVC_21801" in {entry.code for entry in result.scenario.oracle}
