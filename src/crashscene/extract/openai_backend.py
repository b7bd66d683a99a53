"""Chat backend for any OpenAI-compatible endpoint (OpenAI, Ollama, vLLM, llama.cpp servers).

One `ChatBackend` is one configured client: model, base URL, timeout and a
retry policy. `complete(messages)` sends one structured-output request
(`chat.completions.parse` with the strict `LlmScenario` schema) and returns the
parsed reply with its token usage. Transport trouble (timeouts, connection
errors, 429, 5xx) is retried with a deterministic, bounded backoff; what is
still failing after the last attempt becomes a `BackendError` naming the
endpoint, the model and the last error. A reply that does not fit the schema
is *not* retried here: it comes back as `Completion.invalid` so the caller's
re-ask loop can feed the problem back to the model.
"""
from __future__ import annotations

import base64
import io
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from crashscene.extract.errors import ExtractError
from crashscene.extract.llm_schema import LlmScenario

DEFAULT_MODEL = "gpt-4o-mini"
DEFAULT_TIMEOUT = 120.0  # [s] per request
MAX_IMAGE_SIDE = 1568  # [px] larger sketches are downscaled before upload (detail beyond this is not read)

# USD per million tokens (input, cached input, output), list prices; the one place to update when they change.
PRICES_PER_MTOK: dict[str, tuple[float, float, float]] = {
    "gpt-4o-mini": (0.15, 0.075, 0.60),
    "gpt-4o": (2.50, 1.25, 10.00),
    "gpt-4.1": (2.00, 0.50, 8.00),
    "gpt-4.1-mini": (0.40, 0.10, 1.60),
    "gpt-4.1-nano": (0.10, 0.025, 0.40),
    "gpt-5-mini": (0.25, 0.025, 2.00),
    "gpt-5-nano": (0.05, 0.005, 0.40),
}


class BackendError(ExtractError):
    """An LLM endpoint failed (after retries) or is misconfigured."""


class RetryPolicy(BaseModel):
    """Deterministic, bounded retries: delay = min(base * 2**attempt, cap), or the server's Retry-After."""

    model_config = ConfigDict(frozen=True)

    max_retries: int = Field(default=4, ge=0, le=10)
    base_delay: float = Field(default=1.0, ge=0.0, description="[s] before the first retry")
    max_delay: float = Field(default=20.0, ge=0.0, description="[s] cap on one wait, Retry-After included")

    def delay(self, attempt: int, retry_after: float | None = None) -> float:
        """Seconds to wait before retry number `attempt` (0-based)."""
        if retry_after is not None and retry_after >= 0:
            return min(retry_after, self.max_delay)
        return min(self.base_delay * 2 ** attempt, self.max_delay)


class Usage(BaseModel):
    """Tokens spent; summed over every request made for one case."""

    prompt_tokens: int = 0
    cached_tokens: int = 0  # of prompt_tokens, served from the endpoint's prompt cache (cheaper, faster)
    completion_tokens: int = 0
    requests: int = 0

    @property
    def total_tokens(self) -> int:
        return self.prompt_tokens + self.completion_tokens

    def add(self, other: Usage) -> None:
        self.prompt_tokens += other.prompt_tokens
        self.cached_tokens += other.cached_tokens
        self.completion_tokens += other.completion_tokens
        self.requests += other.requests


@dataclass
class Completion:
    """One reply: parsed when it fits the schema, else `invalid` says why (raw text kept for the re-ask)."""

    parsed: LlmScenario | None
    content: str
    usage: Usage
    invalid: str | None = None


@dataclass
class ChatBackend:
    """A configured OpenAI-compatible chat endpoint."""

    model: str = DEFAULT_MODEL
    base_url: str | None = None
    api_key: str | None = None
    timeout: float = DEFAULT_TIMEOUT
    retry: RetryPolicy = field(default_factory=RetryPolicy)
    send_image: bool = True  # False for text-only models (the local backend): sketch facts only
    name: str = "openai"
    priced: bool = True  # False for a local model: cost 0
    max_tokens: int = 2048
    sleep: Callable[[float], None] = time.sleep
    _client: Any = None

    @property
    def client(self) -> Any:
        if self._client is None:
            import openai

            key = self.api_key or os.environ.get("OPENAI_API_KEY")
            if not key:
                if self.base_url is None:
                    raise BackendError("the openai backend needs OPENAI_API_KEY in the environment (or --base-url "
                                       "for a local OpenAI-compatible server; or use --backend rules)")
                key = "not-needed"  # Ollama, vLLM and llama.cpp servers accept any key
            # retries are ours (deterministic and logged), not the SDK's
            self._client = openai.OpenAI(api_key=key, base_url=self.base_url, timeout=self.timeout, max_retries=0)
        return self._client

    @property
    def endpoint(self) -> str:
        return self.base_url or "https://api.openai.com/v1"

    def cost(self, usage: Usage) -> float | None:
        """USD for `usage` at list price; None when the model's price is unknown."""
        if not self.priced:
            return 0.0
        price = price_for(self.model)
        if price is None:
            return None
        fresh = usage.prompt_tokens - usage.cached_tokens
        return (fresh * price[0] + usage.cached_tokens * price[1] + usage.completion_tokens * price[2]) / 1e6

    def complete(self, messages: list[dict[str, Any]]) -> Completion:
        """One structured-output request, with retries on transport errors, 429 and 5xx."""
        import openai

        last: Exception | None = None
        for attempt in range(self.retry.max_retries + 1):
            try:
                raw = self.client.chat.completions.with_raw_response.parse(
                    model=self.model, messages=messages, response_format=LlmScenario, temperature=0, seed=0,
                    max_tokens=self.max_tokens)
            except (openai.APITimeoutError, openai.APIConnectionError, openai.RateLimitError,
                    openai.InternalServerError) as exc:
                last = exc
            except openai.APIStatusError as exc:
                if exc.status_code < 500 and exc.status_code not in (408, 409, 429):
                    raise BackendError(f"{self.name} backend: {self.endpoint} refused the request for model "
                                       f"{self.model!r}: HTTP {exc.status_code}: {_brief(exc)}") from None
                last = exc
            else:
                return _completion(raw, self.max_tokens)
            if attempt < self.retry.max_retries:
                self.sleep(self.retry.delay(attempt, _retry_after(last)))
        raise BackendError(f"{self.name} backend: {self.endpoint} (model {self.model!r}) still failing after "
                           f"{self.retry.max_retries + 1} attempts: {_brief(last)}")


def _completion(raw: Any, max_tokens: int) -> Completion:
    """Parse a raw HTTP reply; a reply that does not fit the schema keeps its text for the re-ask."""
    import openai

    try:
        response = raw.parse()
    except openai.LengthFinishReasonError:
        _, usage = _raw_reply(raw)  # the cut-off text is not worth sending back
        return Completion(None, "", usage, invalid=f"the reply was cut off at the limit of {max_tokens} tokens: "
                          "keep quotes short and list each actor, quote and violation once")
    except openai.ContentFilterFinishReasonError:
        _, usage = _raw_reply(raw)
        return Completion(None, "", usage, invalid="the reply was stopped by the endpoint's content filter")
    except ValueError as exc:  # pydantic ValidationError, JSON decode errors
        content, usage = _raw_reply(raw)
        return Completion(None, content, usage, invalid=f"the reply does not fit the schema: {_first_lines(exc)}")
    message = response.choices[0].message
    usage = _usage(response)
    if message.refusal:
        return Completion(None, message.content or "", usage, invalid=f"refused: {message.refusal}")
    if message.parsed is None:
        return Completion(None, message.content or "", usage, invalid="the reply is empty")
    return Completion(message.parsed, message.content or "", usage)


def _raw_reply(raw: Any) -> tuple[str, Usage]:
    try:
        body = raw.http_response.json()
        content = body["choices"][0]["message"].get("content") or ""
        tokens = body.get("usage") or {}
        cached = (tokens.get("prompt_tokens_details") or {}).get("cached_tokens") or 0
        return content, Usage(prompt_tokens=tokens.get("prompt_tokens") or 0, cached_tokens=cached,
                              completion_tokens=tokens.get("completion_tokens") or 0, requests=1)
    except (ValueError, KeyError, IndexError, TypeError, AttributeError):
        return "", Usage(requests=1)


def _first_lines(exc: Exception, limit: int = 6) -> str:
    return "; ".join(str(exc).splitlines()[:limit])


def price_for(model: str) -> tuple[float, float, float] | None:
    """(input, cached input, output) USD per million tokens; dated snapshots ("gpt-4o-mini-2024-07-18") use the base price."""
    if model in PRICES_PER_MTOK:
        return PRICES_PER_MTOK[model]
    for name in sorted(PRICES_PER_MTOK, key=len, reverse=True):
        if model.startswith(name + "-20"):
            return PRICES_PER_MTOK[name]
    return None


def image_part(path: Path) -> dict[str, Any]:
    """The sketch as an OpenAI image content part (data URL), downscaled to MAX_IMAGE_SIDE."""
    from PIL import Image

    data = path.read_bytes()
    mime = "image/png" if data.startswith(b"\x89PNG") else "image/jpeg"
    with Image.open(io.BytesIO(data)) as image:
        if max(image.size) > MAX_IMAGE_SIDE:
            image.thumbnail((MAX_IMAGE_SIDE, MAX_IMAGE_SIDE))
            buffer = io.BytesIO()
            image.convert("RGB").save(buffer, format="JPEG", quality=90)
            data, mime = buffer.getvalue(), "image/jpeg"
    encoded = base64.b64encode(data).decode("ascii")
    return {"type": "image_url", "image_url": {"url": f"data:{mime};base64,{encoded}", "detail": "high"}}


def _usage(response: Any) -> Usage:
    usage = getattr(response, "usage", None)
    if usage is None:
        return Usage(requests=1)
    details = getattr(usage, "prompt_tokens_details", None)
    cached = getattr(details, "cached_tokens", None) or 0
    return Usage(prompt_tokens=usage.prompt_tokens or 0, cached_tokens=cached,
                 completion_tokens=usage.completion_tokens or 0, requests=1)


def _retry_after(exc: Exception | None) -> float | None:
    response = getattr(exc, "response", None)
    if response is None:
        return None
    value = response.headers.get("retry-after")
    try:
        return float(value) if value is not None else None
    except ValueError:
        return None


def _brief(exc: Exception | None) -> str:
    if exc is None:
        return "unknown error"
    text = f"{type(exc).__name__}: {exc}"
    return text if len(text) <= 300 else text[:297] + "..."
