"""`casewatch run CASE - --serve [HOST:]PORT`: a live status page of the run being judged.

Front-door composition. `view.LiveView` ties the run's observer hooks (`RunSinks.on_tick`,
`on_event`) to a `state.LiveState`, renders the page once (`page`) and serves both from
`server.LiveServer`'s own thread; `flags` holds the `run` command's options and is the only
module `run` imports up front (the server's aiohttp is imported when `--serve` is given).
docs/live.md.
"""
