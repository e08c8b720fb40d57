"""A file picker that never sends a file over its size limit: the *Your data* tab's upload (:class:`FilePicker`).

The page's connection carries one message of at most 20 MB (bokeh's server closes a connection that sends more), and
Panel's and BokehJS's ``FileInput`` read and send a file of any size. This picker is a Panel custom component
(:class:`panel.custom.JSComponent`, Panel's public API for a widget of one's own): the browser looks at the chosen
file's size before reading it, sends a file within the limit to the server as one message, and over the limit sends
only its name and size, so that the server refuses it in words. It is a native ``<input type=file>`` with its
``<label>`` and a hint tied to it (``aria-describedby``): operated by keyboard as any file input, named for screen
readers, and its focus ring is the page's.
"""

from __future__ import annotations

import base64
import binascii
from collections.abc import Callable
from typing import Any, ClassVar

import param
from panel.custom import JSComponent

__all__ = ["FilePicker"]

#: the browser's side: a label, the file input and a hint; a chosen file is read only when within ``max_size``
_ESM = """
export function render({ model, el }) {
    const id = `isl-file-${Math.random().toString(36).slice(2)}`;
    const label = document.createElement("label");
    label.htmlFor = id;
    label.textContent = model.label;
    const input = document.createElement("input");
    input.type = "file";
    input.id = id;
    input.accept = model.accept;
    const hint = document.createElement("div");
    hint.id = `${id}-hint`;
    hint.className = "isl-file-hint";
    hint.textContent = model.hint;
    input.setAttribute("aria-describedby", hint.id);
    input.addEventListener("change", () => {
        const file = input.files && input.files[0];
        if (!file) return;
        if (file.size > model.max_size) {  // not read, not sent: its name and size only
            input.value = "";
            model.send_msg({name: file.name, size: file.size});
            return;
        }
        const reader = new FileReader();
        reader.onload = () => {
            const url = String(reader.result);
            model.send_msg({name: file.name, data: url.slice(url.indexOf(",") + 1)});
        };
        reader.onerror = () => model.send_msg({name: file.name, data: null});
        reader.readAsDataURL(file);
    });
    el.append(label, input, hint);
}
"""

_CSS = """
:host { display: flex; flex-direction: column; gap: 2px; font-size: var(--isl-text-font, 14px); }
label { font-weight: 500; }
input { max-width: 100%; }
.isl-file-hint { font-size: var(--isl-tag-font, 12px); color: #555; }
"""


class FilePicker(JSComponent):
    """A file input that sends a file within ``max_size`` bytes and, over it, only the file's name and size.

    ``on_file(data, name)`` is called with the file's bytes (None if the browser's message could not be read);
    ``on_too_large(name, size)`` with the name and the size in bytes, as text, of a file the browser did not send."""

    label = param.String(default="file", doc="the input's visible name")
    hint = param.String(default="", doc="a line below the input, read with it by screen readers")
    accept = param.String(default="", doc="the file types offered, as the HTML accept attribute")
    max_size = param.Integer(default=1, bounds=(1, None), doc="the largest file sent, in bytes")

    _esm: ClassVar[str] = _ESM
    _stylesheets: ClassVar[list[str]] = [_CSS]

    def __init__(
        self,
        on_file: Callable[[bytes | None, str], None],
        on_too_large: Callable[[str, str], None],
        **params: Any,
    ) -> None:
        super().__init__(**params)
        self._on_file, self._on_too_large = on_file, on_too_large

    def _handle_msg(self, msg: Any) -> None:
        """The browser's message about a chosen file: its contents (base64) or, over the limit, its size."""
        if not isinstance(msg, dict):
            return
        name = str(msg.get("name") or "")[:200]
        if "size" in msg:
            self._on_too_large(name, str(msg["size"]))
            return
        text = msg.get("data")
        try:
            data = base64.b64decode(text, validate=True) if isinstance(text, str) else None
        except (binascii.Error, ValueError):
            data = None
        self._on_file(data, name)
