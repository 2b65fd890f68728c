// ARIA tabs: click or the left and right arrow keys select a tab of a tab list.

export function arrowKeys(tabs, select) {
  for (const [k, tab] of tabs.entries()) {
    tab.addEventListener("click", () => select(tab));
    tab.addEventListener("keydown", (ev) => { // arrow keys move between tabs (ARIA tabs)
      const step = { ArrowRight: 1, ArrowLeft: -1 }[ev.key];
      if (!step) return;
      const next = tabs[(k + step + tabs.length) % tabs.length];
      next.focus();
      select(next);
    });
  }
}
