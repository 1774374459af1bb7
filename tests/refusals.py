"""The refusal every bad input gets (docs/design.md, "Reliability"): exit status 2 and one line,
``enn-traffic: error: ...``, naming the file (or one of several) and the key; the command line's
own refusals (argparse's) too."""

from __future__ import annotations

from enn_traffic import cli
from enn_traffic.core.errors import shown


def refusal(capsys, argv: list, names: tuple | object = (), key: str | None = None) -> str:
    """Run the command line in-process (a traceback fails the test with the exception itself);
    it must exit 2 with one line naming one of ``names`` and ``key``. Returns the line."""
    try:
        status = cli.main([str(a) for a in argv])
    except SystemExit as exit:  # the command line's own refusal
        status = exit.code
    message = capsys.readouterr().err.strip()
    assert status == 2, f"exit {status}: {message}"
    assert message.startswith("enn-traffic: error: ") and "\n" not in message, message
    names = names if isinstance(names, tuple) else (names,)
    if names:
        assert any(str(name) in message or shown(str(name)) in message for name in names), \
            message  # a file inside the working folder is named relative to it
    if key:
        assert key in message, message
    return message
