// Numbers the API answers as null where there is none (no limit, a quantity the input does not
// determine, ...): shown as "n/a" with a title saying why, never as 0 and never as an error of
// the page.

/** The text of `x`: `format(x)` for a finite number, else null. */
const shown = (x, format) => (typeof x === "number" && Number.isFinite(x) ? format(x) : null);

/** A <span>: `format(x)` for a finite number x; else "n/a" (class `no-value`) titled `why`. */
export function numberNode(x, format, why) {
  const span = document.createElement("span");
  const text = shown(x, format);
  if (text === null) {
    span.className = "no-value";
    span.title = why;
    span.textContent = "n/a";
  } else {
    span.textContent = text;
  }
  return span;
}
