"""The world: the typed scenario, the one builder every entry point calls, and
running it (pacing, signals, the step table and the summary)."""
