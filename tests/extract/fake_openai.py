"""A small OpenAI-compatible chat server on 127.0.0.1 for tests (stdlib http.server in a thread).

It answers `POST /v1/chat/completions` from a script, one step per request:
a reply (any JSON-able object as the message content), an HTTP error status
(optionally with headers), or a delay before the next step's answer (to make the
client time out). Every request body is kept for assertions.
"""
from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass
class Step:
    """One scripted answer: `content` (a reply), or `status` (an error), after `delay` seconds."""

    content: Any = None
    status: int = 200
    headers: dict[str, str] = field(default_factory=dict)
    delay: float = 0.0  # [s]
    prompt_tokens: int = 1000
    completion_tokens: int = 200
    cached_tokens: int = 0
    finish_reason: str = "stop"


def reply(content: Any, **kwargs: Any) -> Step:
    return Step(content=content, **kwargs)


def error(status: int, headers: dict[str, str] | None = None) -> Step:
    return Step(status=status, headers=headers or {})


def stall(seconds: float) -> Step:
    """Answer nothing useful for `seconds` (the client times out), then a 500 if it is still listening."""
    return Step(status=500, delay=seconds)


class FakeOpenAI:
    """Context manager: `with FakeOpenAI([steps]) as server: server.base_url, server.requests`."""

    def __init__(self, steps: list[Step]):
        self.steps = list(steps)
        self.requests: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:  # keep test output clean
                pass

            def do_POST(self) -> None:  # noqa: N802  (http.server's naming)
                length = int(self.headers.get("content-length", 0))
                body = json.loads(self.rfile.read(length) or b"{}")
                with fake._lock:
                    fake.requests.append(body)
                    step = fake.steps.pop(0) if fake.steps else Step(status=599)
                if step.delay:
                    time.sleep(step.delay)
                if step.status != 200:
                    payload = json.dumps({"error": {"message": f"scripted {step.status}", "type": "test"}})
                    self._send(step.status, payload, step.headers)
                    return
                content = step.content if isinstance(step.content, str) else json.dumps(step.content)
                completion = {
                    "id": f"chatcmpl-{len(fake.requests)}", "object": "chat.completion", "created": 0,
                    "model": body.get("model", "test"),
                    "choices": [{"index": 0, "finish_reason": step.finish_reason,
                                 "message": {"role": "assistant", "content": content, "refusal": None}}],
                    "usage": {"prompt_tokens": step.prompt_tokens, "completion_tokens": step.completion_tokens,
                              "total_tokens": step.prompt_tokens + step.completion_tokens,
                              "prompt_tokens_details": {"cached_tokens": step.cached_tokens}},
                }
                self._send(200, json.dumps(completion), {})

            def _send(self, status: int, payload: str, headers: dict[str, str]) -> None:
                data = payload.encode()
                try:
                    self.send_response(status)
                    self.send_header("content-type", "application/json")
                    self.send_header("content-length", str(len(data)))
                    for key, value in headers.items():
                        self.send_header(key, value)
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (timeout test)

        self._server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._server.daemon_threads = True
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)

    @property
    def base_url(self) -> str:
        host, port = self._server.server_address[:2]
        return f"http://{host}:{port}/v1"

    def __enter__(self) -> FakeOpenAI:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._server.shutdown()
        self._server.server_close()
