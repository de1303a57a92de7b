"""What every benchmark does last: its topic's table written to ``benchmarks/TOPIC.md``
(``run_all.py`` joins those into README.md) and printed."""

from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).resolve().parent


def publish(topic: str, lines: list[str]) -> int:
    """Write ``lines`` (one newline at the end) to ``TOPIC.md``, print them; the exit code 0."""
    text = "\n".join(lines).rstrip("\n") + "\n"
    (HERE / f"{topic}.md").write_text(text)
    print(text)
    return 0
