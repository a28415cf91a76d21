"""Speed against accuracy for every method (issue 4): scenarios with analytic ground truths,
Cycles bakes timed side by side, charts and tables; and the stability suite."""
