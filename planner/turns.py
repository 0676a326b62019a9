"""The turns of a fleet driven in lockstep (the offline run): each agent decides once
an iteration, in order, and most of a crowd's decisions are waits."""

from __future__ import annotations

from collections.abc import Container, Iterator, Sequence

from planner.agent import WAIT, Action, ActionKind
from planner.coordinator import Coordinator


def decide_until_action(
    coordinator: Coordinator, agents: Sequence[int], start: int, skip: Container[int]
) -> tuple[int, Action]:
    """``decide`` for ``agents[start:]`` in turn, but those in ``skip``, until one does
    more than wait: its position in ``agents`` and its action, or
    ``(len(agents), WAIT)`` when all waited. The same decisions as a call for each
    agent, without a call from the caller's loop for every wait."""
    decide, n = coordinator.decide, len(agents)
    while start < n:
        agent = agents[start]
        if agent not in skip:
            action = decide(agent)
            if action.kind != ActionKind.WAIT:
                return start, action
        start += 1
    return n, WAIT


def acting(
    coordinator: Coordinator, agents: Sequence[int], skip: Container[int]
) -> Iterator[tuple[int, Action]]:
    """An iteration's turns: the agents of ``agents`` (but those in ``skip``) that do
    more than wait, with their actions, lazily: each decides after the one before
    was carried out."""
    k, n = 0, len(agents)
    while True:
        k, action = decide_until_action(coordinator, agents, k, skip)
        if k == n:
            return
        yield agents[k], action
        k += 1
