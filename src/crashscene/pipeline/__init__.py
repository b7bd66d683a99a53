"""Orchestrators above the stages: each runs several stages in order and keeps their artefacts.

`simulate.simulate_scenario`: render -> sample -> simulate -> monitor for one
scenario (`crashscene simulate`); `run.run_case`: one crash report through
extraction and a one-case campaign to the HTML report (`crashscene run`).
The stages themselves (`extract`, `dsl`, `render`, `simulate`, `monitor`,
`campaign`, `report`) never import from here, except the campaign's workers,
which run `simulate_scenario` on each chunk.
"""
