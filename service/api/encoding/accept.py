"""Content negotiation of an answer's form from the request's `Accept` header (RFC 9110 §12.5.1).

A computing route answers JSON (`application/json`, the default), the binary form
(`application/vnd.robodyn.safetensors`) or the progress stream (`application/x-ndjson`). Each
media range may carry a quality `q` in [0, 1] (1 when absent); `q=0` means "not acceptable".
The form chosen is the one of highest `q` among the forms the request names explicitly; a tie
goes to the stream (it carries the JSON answer), then to the binary form. Wildcards (`*/*`,
`application/*`) accept every form at their `q`, so they never outrank a form named explicitly.
"""

from __future__ import annotations

JSON = "application/json"


def qualities(accept: str) -> dict[str, float]:
    """The quality of each media range of an `Accept` header (lower-cased), the highest where a
    range is repeated. An unreadable `q` counts as 1, as if it were absent."""
    found: dict[str, float] = {}
    for media_range in accept.lower().split(","):
        media_type, *parameters = (part.strip() for part in media_range.split(";"))
        if not media_type:
            continue
        q = 1.0
        for parameter in parameters:
            name, _, value = parameter.partition("=")
            if name.strip() == "q":
                try:
                    q = min(max(float(value.strip()), 0.0), 1.0)
                except ValueError:
                    q = 1.0
                if q != q:  # NaN
                    q = 1.0
        found[media_type] = max(q, found.get(media_type, 0.0))
    return found


def prefers(accept: str, form: str, *others: str) -> bool:
    """Whether `accept` asks for `form`: named explicitly with q > 0, and no form of `others`
    (nor JSON) named with a higher q."""
    if form not in accept.lower():  # the common case, without parsing
        return False
    q = qualities(accept)
    wanted = q.get(form, 0.0)
    if wanted <= 0.0:
        return False
    return all(q.get(other, 0.0) <= wanted for other in (*others, JSON))
