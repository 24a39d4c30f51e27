"""The vision-language grounder against a local stub of an OpenAI-compatible endpoint (no network)."""

from __future__ import annotations

import base64
import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

import itup_jax as itup
from itup_jax import grounding
from itup_jax.vlm import VLMError, VLMGrounder, describe


class Stub:
    """A chat-completions stub: `mode` chooses the reply; `requests` records what it received."""

    def __init__(self):
        self.mode, self.answer, self.requests = "ok", {}, []
        stub = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *a):
                pass

            def do_POST(self):
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                stub.requests.append({"path": self.path, "headers": dict(self.headers), "body": body})
                if stub.mode == "slow":
                    time.sleep(1.5)
                if stub.mode == "http500":
                    self.send_response(500)
                    self.end_headers()
                    self.wfile.write(b"model overloaded")
                    return
                msg = {"role": "assistant", "content": json.dumps(stub.answer)}
                if stub.mode == "refusal":
                    msg = {"role": "assistant", "content": None, "refusal": "I cannot help with tools."}
                elif stub.mode == "refusal_text":
                    msg = {"role": "assistant", "content": "Sorry, I cannot do that."}
                elif stub.mode == "prose":
                    msg = {"role": "assistant", "content": "The hammer, obviously."}
                elif stub.mode == "fenced":
                    msg = {"role": "assistant", "content": "```json\n" + json.dumps(stub.answer) + "\n```"}
                elif stub.mode == "not_json":
                    self.send_response(200)
                    self.end_headers()
                    self.wfile.write(b"<html>proxy error</html>")
                    return
                data = json.dumps({"choices": [{"index": 0, "message": msg}]}).encode()
                self.send_response(200)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                try:
                    self.wfile.write(data)
                except BrokenPipeError:  # the client gave up (timeout test)
                    pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/v1"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()


@pytest.fixture(scope="module")
def stub():
    s = Stub()
    yield s
    s.server.shutdown()


@pytest.fixture(scope="module")
def table():
    from itup_jax import tabletop

    return tabletop.make_tabletop(seed=0)


def test_happy_path_sends_text_and_picture_and_validates_the_answer(stub, table, monkeypatch):
    monkeypatch.setenv("STUB_KEY", "sk-test")
    stub.mode, stub.answer = "ok", {"task": "hammer", "tool": 1, "work_part": "1b", "grasp_part": "handle"}
    g = VLMGrounder(url=stub.url, model="stub-vl", api_key_env="STUB_KEY", timeout=5).ground("drive the nail", table)
    assert (g.task, g.tool_name, g.work_part, g.grasp_part, g.grounder) == ("hammer", "hammer", "head", "handle", "vlm")
    req = stub.requests[-1]
    assert req["path"] == "/v1/chat/completions" and req["headers"]["Authorization"] == "Bearer sk-test"
    body = req["body"]
    assert body["model"] == "stub-vl" and body["messages"][0]["role"] == "system"
    text, image = body["messages"][1]["content"]
    assert "drive the nail" in text["text"] and "tool 1: hammer" in text["text"] and "1b head (work)" in text["text"]
    png = base64.b64decode(image["image_url"]["url"].split(",", 1)[1])
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    # the answer in a fenced block is read too; the grounded tool is the scene's
    stub.mode = "fenced"
    g = VLMGrounder(url=stub.url, model="m", timeout=5, image=False).ground("drive the nail", table)
    assert len(stub.requests[-1]["body"]["messages"][1]["content"]) == 1  # text only
    assert g.grounded_tool(table).name == "hammer"


@pytest.mark.parametrize("mode,answer,words", [
    ("refusal", {}, "model refused: I cannot help"),
    ("refusal_text", {}, "model refused: Sorry"),
    ("prose", {}, "not a JSON object"),
    ("not_json", {}, "did not answer with JSON"),
    ("http500", {}, "HTTP 500: model overloaded"),
    ("ok", {"task": "hammer", "tool": 1}, "lacks work_part, grasp_part"),
    ("ok", {"task": "hammer", "tool": 7, "work_part": "a", "grasp_part": "a"}, "tool 7 is not on the table"),
    ("ok", {"task": "juggle", "tool": 1, "work_part": "b", "grasp_part": "a"}, "unknown task 'juggle'"),
    ("ok", {"task": "hammer", "tool": 1, "work_part": "handle", "grasp_part": "a"}, "no contact annotation"),
    ("ok", {"task": "hammer", "tool": 1, "work_part": "2b", "grasp_part": "a"}, "belongs to tool 2"),
    ("ok", {"task": "hammer", "tool": 1, "work_part": "z", "grasp_part": "a"}, "has no part 'z'"),
])
def test_bad_answers_are_clear_errors(stub, table, mode, answer, words):
    stub.mode, stub.answer = mode, answer
    with pytest.raises(VLMError, match=words):
        VLMGrounder(url=stub.url, model="m", timeout=5, image=False).ground("drive the nail", table)


def test_timeout_unreachable_and_the_rule_fallback(stub, table):
    stub.mode = "slow"
    with pytest.raises(VLMError, match="no answer .* within 0.3 s"):
        VLMGrounder(url=stub.url, model="m", timeout=0.3, image=False).ground("drive the nail", table)
    with pytest.raises(VLMError, match="cannot reach"):
        VLMGrounder(url="http://127.0.0.1:9/v1", model="m", timeout=2, image=False).ground("drive the nail", table)
    g = VLMGrounder(url=stub.url, model="m", timeout=0.3, fallback="rule", image=False).ground("drive the nail", table)
    assert g.grounder == "rule (vlm fallback)" and g.tool_name == "hammer" and "within 0.3 s" in g.notes[0]
    for bad, words in ((dict(url="ftp://x"), "url must start"), (dict(url="http://x", model=""), "model"),
                       (dict(url="http://x", model="m", timeout=0), "timeout"),
                       (dict(url="http://x", model="m", fallback="guess"), "fallback")):
        with pytest.raises(VLMError, match=words):
            VLMGrounder(**{"model": "m", **bad})


@pytest.mark.slow
def test_the_whole_chain_takes_the_vlm_grounding(stub, table):
    stub.mode, stub.answer = "ok", {"task": "knock", "tool": 3, "work_part": "head", "grasp_part": "handle"}
    r = itup.run("knock over the tower", tabletop=table, samples=256,
                 grounder=VLMGrounder(url=stub.url, model="m", timeout=5, image=False))
    assert r.grounding.grounder == "vlm" and r.grounding.tool_name == "mallet" and r.stage != "grounding"
    assert isinstance(describe(table), str) and grounding.TARGETS["knock"] in describe(table)
