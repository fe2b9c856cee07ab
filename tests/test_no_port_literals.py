"""No test hard-codes a port: every port a test binds comes from the allocator or the OS.

Fixed ports collide: two pytest-xdist workers (or two CI jobs) pick the same one, or a port in
Linux's ephemeral range (32768-60999) goes to some process's outgoing connection before the
test binds it. Tests take ports from :func:`harness.run.ports.free_ports` /
:func:`harness.run.ports.free_port_block` (this worker's own slice of 20000-32767) or let the OS
choose (port 0). This lint reads every ``tests/**/*.py`` with :mod:`tokenize` and flags, on a
line about ports (:data:`PORT_WORDS`), an integer literal in 1024-65535, a string that is such a
number (``"--sdk-port", "45150"``) or a string with one after a ``:`` (``"127.0.0.1:47110"``,
``"udpin://0.0.0.0:14540"``). Not flagged: comments, lines about baud rates, and a receive
buffer size (``sock.recv(65535)``). A line that compares against a documented default without
binding it carries the marker ``# port-literal: <why>``, e.g.
``# port-literal: PX4's default, not bound``.
"""

from __future__ import annotations

import io
import re
import tokenize
from dataclasses import dataclass
from pathlib import Path

import pytest

TESTS_DIR = Path(__file__).resolve().parent
LOW, HIGH = 1024, 65535
"""Integers in this range on a port line are taken for ports (below 1024: not a test's port)."""
PORT_WORDS = re.compile(
    r"(?<![a-z])(?:port|addr|udp|tcp|bind|url|base|localhost)|127\.0\.0\.1|0\.0\.0\.0"
    r"|\b\d{1,3}(?:\.\d{1,3}){3}:\d",
    re.I,
)
"""A line mentioning one of these is about ports (``BASE = 48000``, ``("127.0.0.1", 46250)``,
any ``a.b.c.d:port``); a word only at the start of a name part (``sdk_port``, ``Ports``; not
``UNSUPPORTED``)."""
NOT_PORT_WORDS = re.compile(r"baud|\bBd\b", re.I)
"""A line about a serial line's speed (921600, 57600 Bd) is not about ports."""
ALLOW = re.compile(r"#\s*port-literal:\s*\S")
"""The per-line marker of a literal that is no bound port (a reason must follow the colon)."""
NUMBER_IN_STRING = re.compile(r"(?:^|:\{?\s*)(\d+)\b")
"""A number starting a string or following a ``:`` in it (also ``f"...:{42060 + i}"``)."""
BUFFER_CALLS = frozenset({"recv", "recvfrom", "recv_into", "read"})
"""``sock.recv(65535)``: the first argument of these is a buffer size, not a port."""


@dataclass(frozen=True)
class Offender:
    """One port literal: where, and the token it is in."""

    path: Path
    line: int
    text: str

    def __str__(self) -> str:
        return f"{self.path.relative_to(TESTS_DIR.parent)}:{self.line}: {self.text}"


def _is_port(value: int) -> bool:
    return LOW <= value <= HIGH


def _int_value(token: str) -> int | None:
    """The value of an integer literal token (``45_150``, ``0xB000``), None for a float."""
    try:
        return int(token, 0)
    except ValueError:
        return None


def port_literals(path: Path, source: str | None = None) -> list[Offender]:
    """The port literals of one Python file (``source`` instead of the file's text if given)."""
    text = path.read_text() if source is None else source
    lines = text.splitlines()
    tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
    out: list[Offender] = []

    def about_ports(row: int, extra: str = "") -> bool:
        line = lines[row - 1] if row <= len(lines) else ""
        if ALLOW.search(line) or NOT_PORT_WORDS.search(line + extra):
            return False
        return bool(PORT_WORDS.search(line + extra))

    for k, tok in enumerate(tokens):
        row = tok.start[0]
        if tok.type == tokenize.NUMBER:
            value = _int_value(tok.string)
            if value is None or not _is_port(value) or not about_ports(row):
                continue
            before = [t.string for t in tokens[max(k - 2, 0) : k]]
            after = tokens[k + 1].string if k + 1 < len(tokens) else ""
            if len(before) == 2 and before[0] in BUFFER_CALLS and before[1] == "(" and after == ")":
                continue  # sock.recv(65535): a buffer size
            out.append(Offender(path, row, tok.string))
        elif tok.type == tokenize.STRING:
            body = tok.string
            for match in NUMBER_IN_STRING.finditer(body.lstrip("rRbBuUfF").strip("'\"")):
                if not _is_port(int(match.group(1))):
                    continue
                head = body.lstrip("rRbBuUfF").strip("'\"")[: match.start(1)]
                at = row + head.count("\n")
                string_line = body.splitlines()[head.count("\n")] if "\n" in body else body
                if about_ports(at, string_line):
                    out.append(Offender(path, at, match.group(0).strip()))
    return out


def test_no_test_hard_codes_a_port():
    """Every tests/**/*.py but this file (whose examples are port literals on purpose)."""
    paths = [p for p in sorted(TESTS_DIR.rglob("*.py")) if p != Path(__file__).resolve()]
    offenders = [o for path in paths for o in port_literals(path)]
    if offenders:
        pytest.fail(
            "port literals in tests (take ports from harness.run.ports.free_port_block or "
            "free_ports, or port 0; a default compared without binding gets "
            "'# port-literal: <why>'):\n" + "\n".join(str(o) for o in offenders),
            pytrace=False,
        )


def lint(source: str) -> list[int]:
    """The lines of ``source`` the lint flags."""
    return [o.line for o in port_literals(TESTS_DIR / "snippet.py", source)]


def test_the_lint_flags_ports_in_numbers_strings_and_urls():
    assert lint("BASE = 48000\n") == [1]
    assert lint('sink.bind(("127.0.0.1", 45150))\n') == [1]
    assert lint('args = ["--sdk-port", "45150"]\n') == [1]
    assert lint('url = "udpin://0.0.0.0:14540"\n') == [1]
    assert lint('nodes = {"cloud": {"address": "127.0.0.1:47110"}}\n') == [1]
    assert lint('peer = f"127.0.0.1:{42060 + i} --mavlink udpout:127.0.0.1:{42050 + i}"\n') == [
        1,
        1,
    ]
    assert lint('routes = {"fog1": "255.255.255.255:46025"}\n') == [1]
    assert lint('x = 1\nDOC = """\nlisten on\n127.0.0.1:46000\n"""\n') == [4]


def test_the_lint_leaves_other_numbers_and_marked_defaults_alone():
    assert lint("ack = command_long(40123, target_component=1)\n") == []
    assert lint("assert version.capabilities == 59871\n") == []
    assert lint('table = "uart 921600 Bd 8N1 / sik 57600 Bd 8N1"  # baud\n') == []
    assert lint("data, address = sock.recvfrom(65535)\n") == []
    assert lint("rate_bps = 46080  # the UART's byte rate\n") == []
    assert lint("base_port = 80\nsdk_base = 0.5 * 20000.0\n") == []
    assert lint("assert listen_port(0) == 14580  # port-literal: PX4's default, not bound\n") == []
    assert lint("port = 14580  # port-literal:\n") == [1]  # the marker needs a reason
    assert lint("# sends to port 14540\n") == []
    assert lint("assert (ack.command, ack.result) == (31000, UNSUPPORTED)\n") == []
