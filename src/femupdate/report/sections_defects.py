"""The report's section on the defects found in the records (shown only when there are any)."""

from __future__ import annotations

from collections.abc import Sequence

from femupdate.pipeline.results import DefectRecord
from femupdate.report.markup import esc, note, table, td, warn

__all__ = ["section_defects"]

_STATUS = {"open": ("fail", "open: the runs are no success"), "repaired": ("ok", "repaired"),
           "accepted": ("", "accepted ([data] accept)")}


def section_defects(defects: Sequence[DefectRecord]) -> str:
    """A table of the defects (trial, file, channel, kind, evidence, repair, status); "" when
    the checks found nothing."""
    if not defects:
        return ""
    rows = []
    for d in defects:
        cls, status = _STATUS[d.status]
        rows.append([td(esc(d.trial)), td(esc(d.file)), td(esc(d.channel)), td(esc(d.kind)),
                     td(esc(d.evidence)), td(esc(d.repair)), td(esc(status), cls)])
    blocking = [d for d in defects if d.status == "open" and d.severity == "error"]
    head = (warn(f"{len(blocking)} defect(s) in the records were neither repaired nor "
                 "accepted: no run of this fit counts as a success.", "defects-open")
            if blocking else note("Every defect found was repaired or accepted by the case."))
    return head + table(["trial", "file", "channel", "kind", "evidence", "repair", "status"],
                        rows, table_id="defects",
                        caption="What the checks of the records found (docs/data-checks.md)")
