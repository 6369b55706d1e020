"""Read-only mapping fields of frozen records, and how such records are pickled.

Records such as :class:`matid.model.study.Test` and :class:`matid.model.measurement.Measurement` hold their
mappings as ``types.MappingProxyType`` views so that nobody edits a study after it was checked.
A mappingproxy cannot be pickled, and the report is rendered in another process
(:mod:`matid.app.render_worker`), so :class:`PicklesViews` pickles each view as the plain dict
behind it and restores the view (with any numpy arrays in it read-only again) on loading.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np


class PicklesViews:
    """Mixin for frozen dataclasses whose mapping fields are MappingProxyType views."""

    def __getstate__(self) -> tuple[dict, tuple[str, ...]]:
        state = dict(vars(self))
        views = tuple(name for name, value in state.items() if isinstance(value, MappingProxyType))
        for name in views:
            state[name] = dict(state[name])
        return state, views

    def __setstate__(self, saved: tuple[dict, tuple[str, ...]]) -> None:
        state, views = saved
        for name, value in state.items():
            if name in views:
                for item in value.values():
                    if isinstance(item, np.ndarray):
                        item.setflags(write=False)
                value = MappingProxyType(value)
            object.__setattr__(self, name, value)
