"""The settings' help (`python -m service --help`, the deployment docs' table) names the answer
a limit gives as `<status> <code>`: each such pair is the status the service answers that code
with."""

from __future__ import annotations

import re

from service.api.problems.handlers import STATUS_BY_CODE
from service.settings import Settings

PAIR = re.compile(r"\b([45]\d\d) ([a-z_]+)\b")


def test_every_status_and_code_named_in_a_settings_help_agree() -> None:
    named = [
        (name, int(status), code)
        for name, field in Settings.model_fields.items()
        for status, code in PAIR.findall(field.description or "")
        if code in STATUS_BY_CODE
    ]
    assert any(code == "deadline_exceeded" for _, _, code in named)  # the test reads them
    wrong = [(name, status, code) for name, status, code in named if STATUS_BY_CODE[code] != status]
    assert wrong == []
