"""The replay buffer, where the API reference and older code find it: it lives in
`litl.models.replay_buffer`, below the observers that learn from it and the loop that fills it
(a module here would make `litl.observers` import `litl.loop`, a layer above it).
"""

from litl.models.replay_buffer import (
    ReplayBuffer,
    add,
    clear,
    newest,
    occupied_mean,
    replace_with,
    valid_fields,
    valid_mask,
)

__all__ = [
    "ReplayBuffer",
    "add",
    "clear",
    "newest",
    "occupied_mean",
    "replace_with",
    "valid_fields",
    "valid_mask",
]
