"""The batch's progress lines: done/total, counts, elapsed time and an ETA."""

import time


class Progress:
    """done/total with elapsed time and an ETA from the assets baked so far. Until every file
    is scanned the total counts each unscanned file as the mean of the scanned ones."""

    def __init__(self, log):
        self.log, self.done, self.known, self.unscanned = log, 0, 0, 0
        self.scanned_files, self.scanned_assets = 0, 0
        self.counts = {"baked": 0, "skipped": 0, "failed": 0}
        self.t0 = time.perf_counter()

    @property
    def total(self):
        per_file = self.scanned_assets / self.scanned_files if self.scanned_files else 1
        return self.known + round(self.unscanned * max(per_file, 1))

    def step(self, status, what, detail=""):
        self.done += 1
        self.counts[status] += 1
        elapsed = time.perf_counter() - self.t0
        worked = self.counts["baked"] + self.counts["failed"]
        total = max(self.total, self.done)
        left = total - self.done
        eta = "done" if not left else \
            (f"ETA {elapsed / worked * left:.0f} s" if worked else "ETA ?")
        approx = "~" if self.unscanned else ""
        self.log(f"[{self.done}/{approx}{total}] {status} {what}{detail} | "
                 f"{self.counts['baked']} baked, {self.counts['skipped']} skipped, "
                 f"{self.counts['failed']} failed | {elapsed:.1f} s elapsed, {eta}")
