"""Node core over an in-memory lossy port: requests retry, time out, run handlers once."""

from __future__ import annotations

import json

import pytest
from netfakes import FakePort, ManualClock, make_nodes

from companion.net import MAX_DATAGRAM_BYTES, MessageTooLargeError, RequestTimeout, decode
from companion.net import node as node_module


def run_until_done(nodes, clock, pending, step_s=0.1, limit_s=30.0):
    while not pending.done and clock.t_s < limit_s:
        for node in nodes.values():
            node.poll()
        clock.t_s += step_s
    for node in nodes.values():
        node.poll()


def kinds_sent(port):
    return [(decode(d).kind, decode(d).attempt) for _, _, d in port.sent]


def test_request_reply_without_loss():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "edge1", "fog1")
    nodes["fog1"].on("sum", lambda env: sum(env.body))
    pending = nodes["edge1"].request("fog1", "sum", [1, 2, 3])
    clock.t_s = 0.25
    nodes["fog1"].poll()
    clock.t_s = 0.5
    nodes["edge1"].poll()
    assert pending.done and pending.reply.body == 6 and pending.error is None
    assert pending.rtt_s == pytest.approx(0.5)
    assert pending.reply.reply_to == pending.msg_id


def test_lost_first_copy_is_retried_with_the_same_id():
    clock = ManualClock()
    port = FakePort(drop=lambda src, dst, data, i: i == 0)
    nodes = make_nodes(port, clock, "edge1", "fog1")
    calls = []
    nodes["fog1"].on("ping", lambda env: calls.append(env.attempt) or "pong")
    pending = nodes["edge1"].request("fog1", "ping", None, timeout_s=1.0, retries=3)
    run_until_done(nodes, clock, pending)
    assert pending.reply.body == "pong"
    assert calls == [2]
    assert kinds_sent(port) == [("request", 1), ("request", 2), ("reply", 2)]
    assert {decode(d).msg_id for s, _, d in port.sent if s == "edge1"} == {pending.msg_id}
    # the reply echoes attempt 2, so the RTT is measured from the retransmission
    assert pending.rtt_s < 1.0
    link = nodes["edge1"].stats.peers["fog1"]
    assert link.retries == 1 and link.timeouts == 0


def test_all_copies_lost_raises_timeout_after_retries_plus_one_sends():
    clock = ManualClock()
    port = FakePort(drop=lambda *_: True)
    nodes = make_nodes(port, clock, "edge1", "fog1")
    pending = nodes["edge1"].request("fog1", "ping", None, timeout_s=0.5, retries=2)
    run_until_done(nodes, clock, pending, step_s=0.25)
    assert isinstance(pending.error, RequestTimeout) and pending.reply is None
    assert kinds_sent(port) == [("request", 1), ("request", 2), ("request", 3)]
    assert [decode(d).sent_s for _, _, d in port.sent] == [0.0, 0.5, 1.0]
    assert clock.t_s == 1.75  # failed at the poll of t = 1.5, the third copy's timeout
    link = nodes["edge1"].stats.peers["fog1"]
    assert (link.retries, link.timeouts) == (2, 1)
    assert nodes["edge1"].next_deadline_s() is None


def test_duplicate_request_runs_the_handler_once_and_gets_the_cached_reply():
    """The reply to copy 1 is lost; copy 2 is answered from the cache."""
    clock = ManualClock()
    port = FakePort(drop=lambda src, dst, data, i: decode(data).kind == "reply" and i < 2)
    nodes = make_nodes(port, clock, "edge1", "fog1")
    calls = []
    nodes["fog1"].on("count", lambda env: calls.append(env.msg_id) or len(calls))
    pending = nodes["edge1"].request("fog1", "count", None, timeout_s=1.0)
    run_until_done(nodes, clock, pending)
    assert len(calls) == 1
    assert pending.reply.body == 1 and pending.reply.attempt == 2
    assert nodes["fog1"].stats.duplicate_requests == 1


def test_request_before_its_handler_runs_the_handler_on_the_next_copy():
    """A node still starting gets a request before it has a handler for it: the copy goes to
    poll()'s caller; the retransmission after the handler is set runs it (once) and is answered.
    """
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "fog1", "cloud")
    pending = nodes["fog1"].request("cloud", "register", {"cluster": []}, timeout_s=1.0)
    clock.t_s = 0.1
    (early,) = nodes["cloud"].poll()
    assert early.topic == "register" and not pending.done
    calls = []
    nodes["cloud"].on("register", lambda env: calls.append(env.attempt) or "ok")
    run_until_done(nodes, clock, pending)
    assert pending.reply.body == "ok" and pending.reply.attempt == 2
    assert calls == [2] and nodes["cloud"].stats.duplicate_requests == 0
    # A further copy of the same request is answered from the cache, the handler not run again.
    port.queues["cloud"].append([d for s, _, d in port.sent if s == "fog1"][-1])
    nodes["cloud"].poll()
    assert calls == [2] and nodes["cloud"].stats.duplicate_requests == 1
    assert [decode(d).kind for s, _, d in port.sent if s == "cloud"] == ["reply", "reply"]


def test_late_duplicate_reply_is_counted_and_dropped():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "edge1", "fog1")
    seen = []
    nodes["fog1"].on("q", lambda env: seen.append(env) or "a")
    pending = nodes["edge1"].request("fog1", "q", None)
    nodes["fog1"].poll()
    nodes["fog1"].reply(seen[0], "again")  # a second reply to the same request
    assert nodes["edge1"].poll() == []
    assert pending.reply.body == "a"
    assert nodes["edge1"].stats.late_replies == 1


def test_deferred_reply_from_the_poll_result():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "edge1", "fog1")
    pending = nodes["edge1"].request("fog1", "later", 5)
    (env,) = nodes["fog1"].poll()  # no handler: the request is returned
    assert env.kind == "request"
    nodes["fog1"].reply(env, env.body * 2)
    nodes["edge1"].poll()
    assert pending.reply.body == 10


def test_group_and_broadcast_expand_to_unicasts():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "cloud", "fog1", "edge1", "edge2")
    assert nodes["fog1"].send_group("cluster1", "hello", 1) == 2
    assert nodes["cloud"].broadcast("all", 2) == 3
    received = {n: [(e.src, e.topic) for e in node.poll()] for n, node in nodes.items()}
    assert received == {
        "cloud": [],
        "fog1": [("cloud", "all")],
        "edge1": [("fog1", "hello"), ("cloud", "all")],
        "edge2": [("fog1", "hello"), ("cloud", "all")],
    }
    with pytest.raises(ValueError, match="group"):
        nodes["fog1"].send_group("cluster9", "x", 1)
    with pytest.raises(ValueError, match="dst"):
        nodes["fog1"].send("edge9", "x", 1)


def test_oversized_message_raises_and_sends_nothing():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "cloud", "fog1", "edge1", "edge2")
    big = b"x" * MAX_DATAGRAM_BYTES
    for call in (
        lambda: nodes["cloud"].send("fog1", "img", big),
        lambda: nodes["cloud"].broadcast("img", big),
        lambda: nodes["fog1"].send_group("cluster1", "img", big),
        lambda: nodes["cloud"].request("fog1", "img", big),
    ):
        with pytest.raises(MessageTooLargeError, match="65507"):
            call()
    assert port.sent == []
    assert nodes["cloud"].stats.peers == {} and nodes["cloud"].next_deadline_s() is None


def test_malformed_and_misaddressed_datagrams_are_counted_not_raised():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "edge1", "fog1")
    nodes["edge1"].send("fog1", "t", 1)
    (_, _, good) = port.sent[0]
    port.queues["edge1"] += [b"\x00garbage", b"", good]  # good is addressed to fog1
    assert nodes["edge1"].poll() == []
    assert nodes["edge1"].stats.malformed == 2
    assert nodes["edge1"].stats.misaddressed == 1


def test_stats_count_what_was_sent_and_received():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "cloud", "fog1", "edge1")
    nodes["fog1"].on("ask", lambda env: "ok")
    nodes["edge1"].send("fog1", "tlm", {"x": 1.0})
    nodes["edge1"].send("fog1", "tlm", {"x": 2.0})
    pending = nodes["edge1"].request("fog1", "ask", None)
    nodes["fog1"].send("cloud", "up", "summary")
    clock.t_s = 0.2
    nodes["fog1"].poll()
    nodes["cloud"].poll()
    clock.t_s = 0.3
    nodes["edge1"].poll()
    assert pending.done

    def bytes_of(src, dst, category):
        return sum(
            len(d)
            for s, t, d in port.sent
            if (s, t) == (src, dst) and decode(d).category == category
        )

    edge = nodes["edge1"].stats.to_dict()
    fog = nodes["fog1"].stats.to_dict()
    assert edge["peers"]["fog1"]["sent"]["data"] == {
        "messages": 2,
        "bytes": bytes_of("edge1", "fog1", "data"),
    }
    assert edge["peers"]["fog1"]["sent"]["control"]["messages"] == 1
    assert fog["link_classes"]["edge-fog"]["received"]["data"]["bytes"] == bytes_of(
        "edge1", "fog1", "data"
    )
    assert fog["link_classes"]["edge-fog"]["latency_s"]["data"] == pytest.approx([0.2, 0.2])
    assert fog["link_classes"]["fog-cloud"]["sent"]["data"]["messages"] == 1
    assert edge["link_classes"]["edge-fog"]["rtt_s"] == pytest.approx([0.3])
    json.dumps(edge)


def test_task_intervals_and_records_file(tmp_path):
    clock = ManualClock()
    nodes = make_nodes(FakePort(), clock, "edge1")
    with nodes["edge1"].task("survey"):
        clock.t_s = 4.0
    path = tmp_path / "edge1.json"
    nodes["edge1"].write_records(path)
    records = json.loads(path.read_text())
    assert records["tasks"] == [{"name": "survey", "start_s": 0.0, "end_s": 4.0}]
    assert records["node_id"] == "edge1" and records["send_errors"] == 0


def test_reply_cache_is_bounded(monkeypatch):
    """Beyond the cache size the oldest request is forgotten (its retry would run again)."""
    monkeypatch.setattr(node_module, "REPLY_CACHE_SIZE", 3)
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "edge1", "fog1")
    calls = []
    nodes["fog1"].on("q", lambda env: calls.append(env.body) or env.body)
    for i in range(5):
        nodes["edge1"].request("fog1", "q", i)
    nodes["fog1"].poll()
    resend = [d for s, _, d in port.sent if s == "edge1"]
    port.queues["fog1"] += [resend[0], resend[4]]  # duplicates of the oldest and newest
    nodes["fog1"].poll()
    assert calls == [0, 1, 2, 3, 4, 0]
    assert nodes["fog1"].stats.duplicate_requests == 1


def test_cancelled_request_stops_retransmitting():
    clock = ManualClock()
    port = FakePort(drop=lambda *_: True)
    nodes = make_nodes(port, clock, "edge1", "fog1")
    pending = nodes["edge1"].request("fog1", "q", None, timeout_s=0.5)
    nodes["edge1"].cancel(pending)
    clock.t_s = 10.0
    nodes["edge1"].poll()
    assert len(port.sent) == 1 and not pending.done
    assert nodes["edge1"].next_deadline_s() is None


def test_handler_exception_propagates_and_later_datagrams_wait():
    clock = ManualClock()
    port = FakePort()
    nodes = make_nodes(port, clock, "edge1", "fog1")

    def handler(env):
        if env.body == "bad":
            raise RuntimeError("handler bug")

    nodes["fog1"].on("t", handler)
    nodes["edge1"].send("fog1", "other", 0)
    nodes["edge1"].send("fog1", "t", "bad")
    nodes["edge1"].send("fog1", "other", 1)
    with pytest.raises(RuntimeError, match="handler bug"):
        nodes["fog1"].poll()
    assert [e.body for e in nodes["fog1"].poll()] == [0, 1]
