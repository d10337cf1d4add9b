"""Which topics a recording takes, as ``ros2 bag record`` selects them, and what a topic name says.

Explicit topics, all topics, a regex, an exclude regex, topic types, hidden topics, service events
(``<service>/_service_event``) and action feedback and status (``<action>/_action/feedback``,
``<action>/_action/status``). ROS-free rules on names and types only: the recorder asks them of every
topic it discovers, and ``info``, ``convert`` and the player read topic names with the same helpers.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from feeder_planner.errors import InputError

__all__ = [
    "ACTION_TOPIC_SUFFIXES",
    "DEFAULT_EXCLUDED",
    "SERVICE_EVENT_SUFFIX",
    "Selection",
    "action_of",
    "is_hidden",
    "service_of",
]

# Infrastructure topics every node has; recording them by default only adds noise.
DEFAULT_EXCLUDED = ("/rosout", "/parameter_events")

SERVICE_EVENT_SUFFIX = "/_service_event"
ACTION_TOPIC_SUFFIXES = ("/_action/feedback", "/_action/status")


def service_of(topic: str) -> str | None:
    """Return the service whose events ``topic`` carries, or None for any other topic."""
    return topic[: -len(SERVICE_EVENT_SUFFIX)] if topic.endswith(SERVICE_EVENT_SUFFIX) else None


def action_of(topic: str) -> str | None:
    """Return the action whose feedback or status ``topic`` carries, or None for any other topic."""
    for suffix in ACTION_TOPIC_SUFFIXES:
        if topic.endswith(suffix):
            return topic[: -len(suffix)]
    return None


def is_hidden(topic: str) -> bool:
    """Return whether a name component starts with an underscore (ROS 2 hides such topics)."""
    return any(part.startswith("_") for part in topic.split("/"))


def _compile(flag: str, pattern: str | None) -> re.Pattern[str] | None:
    if pattern is None:
        return None
    try:
        return re.compile(pattern)
    except re.error as exc:
        raise InputError(flag, f"is not a valid regular expression ({exc}): {pattern!r}") from None


@dataclass(frozen=True)
class Selection:
    """Which topics a recording takes, as ``ros2 bag record`` selects them.

    Parameters
    ----------
    topics
        Topics recorded whatever the other rules say (except ``exclude`` and ``topic_types``).
    all_topics
        Every topic except ``DEFAULT_EXCLUDED``, hidden topics (unless ``include_hidden``) and
        service events.
    regex
        Topics whose name matches this regular expression (``re.search``) are recorded.
    exclude
        Topics (service events and action topics included) matching this regex are never recorded.
    topic_types
        When not empty, only topics of these types (``pkg/msg/Type``); service events are not affected.
    include_hidden
        Hidden topics (a name component starting with ``_``) may be taken by ``all_topics`` and ``regex``.
    services
        None: no service events; empty: every service's; else these services' (names, no suffix).
    actions
        None: no action topics; empty: every action's feedback and status; else these actions'.
    """

    topics: tuple[str, ...] = ()
    all_topics: bool = False
    regex: str | None = None
    exclude: str | None = None
    topic_types: tuple[str, ...] = ()
    include_hidden: bool = False
    services: tuple[str, ...] | None = None
    actions: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        _compile("--regex", self.regex)
        _compile("--exclude", self.exclude)
        for type_name in self.topic_types:
            if len(type_name.split("/")) != 3:
                raise InputError("--topic-types", f"must name types as pkg/msg/Type, got {type_name!r}")

    def wants(self, topic: str, type_name: str) -> bool:
        """Return whether ``topic`` (of type ``type_name``) is recorded."""
        exclude = _compile("--exclude", self.exclude)
        if exclude is not None and exclude.search(topic):
            return False
        service = service_of(topic)
        if service is not None:
            return self.services is not None and (not self.services or service in self.services)
        action = action_of(topic)
        if action is not None and self.actions is not None and (not self.actions or action in self.actions):
            return True
        if self.topic_types and type_name not in self.topic_types:
            return False
        if topic in self.topics:
            return True
        if is_hidden(topic) and not self.include_hidden:
            return False
        regex = _compile("--regex", self.regex)
        if regex is not None and regex.search(topic):
            return True
        return self.all_topics and topic not in DEFAULT_EXCLUDED
