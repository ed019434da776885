"""A websocket client speaking viser's protocol (msgpack messages in zstd windows), standing in
for a browser page: for tests and benchmarks that send what a page (or a hostile program) can."""

from __future__ import annotations

import asyncio
import time
from typing import Any

import msgspec
import viser
import websockets
import zstandard


def decode_window(raw: bytes, decompressor: zstandard.ZstdDecompressor) -> list[dict]:
    """The messages of one viser websocket window (see benchmarks/web_speed.py)."""
    inner_size = int.from_bytes(raw[:8], "little")
    compressed_size = int.from_bytes(raw[8:16], "little")
    payload = decompressor.decompress(raw[16: 16 + compressed_size], max_output_size=inner_size)
    return msgspec.msgpack.decode(payload)["messages"]


class Page:
    """A websocket client speaking viser's protocol: ``state`` holds each control's creation
    message by label and every update it received since, in order."""

    def __init__(self, port: int, path: str = "") -> None:
        self.port = port
        self.path = path
        self.controls: dict[str, dict] = {}
        self.updates: list[dict] = []

    async def __aenter__(self) -> Page:
        self.connection = await websockets.connect(
            f"ws://127.0.0.1:{self.port}{self.path}", subprotocols=[f"viser-v{viser.__version__}"],
            max_size=None)
        self.decompressor = zstandard.ZstdDecompressor()
        return self

    async def __aexit__(self, *_: Any) -> None:
        await self.connection.close()

    async def listen(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                raw = await asyncio.wait_for(self.connection.recv(), end - time.monotonic())
            except TimeoutError:
                return
            for message in decode_window(raw, self.decompressor):
                label = message.get("props", {}).get("label") if isinstance(
                    message.get("props"), dict) else None
                if message.get("type", "").startswith("Gui") and label:
                    self.controls[label] = message
                elif message.get("type") == "GuiUpdateMessage":
                    self.updates.append(message)

    def uuid(self, label: str) -> str:
        return self.controls[label]["uuid"]

    def value(self, label: str) -> Any:
        """The value this page shows: the creation message, then the updates in order."""
        value = self.controls[label].get("value")
        for update in self.updates:
            if update["uuid"] == self.uuid(label) and "value" in update["updates"]:
                value = update["updates"]["value"]
        return value

    async def send(self, **message: Any) -> None:
        await self.connection.send(msgspec.msgpack.encode(message))

    async def set(self, label: str, updates: dict) -> None:
        await self.send(type="GuiUpdateMessage", uuid=self.uuid(label), updates=updates)

    async def camera(self) -> None:
        await self.send(type="ViewerCameraMessage", wxyz=(1.0, 0.0, 0.0, 0.0),
                        position=(0.0, 0.0, -5.0), fov=0.9, near=0.01, far=100.0,
                        image_height=600, image_width=800, look_at=(0.0, 0.0, 0.0),
                        up_direction=(0.0, 1.0, 0.0))

    async def upload(self, label: str, filename: str, content: bytes,
                     part_bytes: int = 2**20) -> None:
        """Send ``content`` as a file chosen with the upload button ``label``."""
        button, transfer = self.uuid(label), f"upload-{time.monotonic_ns()}"
        parts = [content[i: i + part_bytes] for i in range(0, len(content), part_bytes)] or [b""]
        await self.send(type="FileTransferStartUpload", source_component_uuid=button,
                        transfer_uuid=transfer, filename=filename, mime_type="application/zip",
                        part_count=len(parts), size_bytes=len(content))
        for index, part in enumerate(parts):
            await self.send(type="FileTransferPart", source_component_uuid=button,
                            transfer_uuid=transfer, part_index=index, content=part)

    def said(self, text: str) -> bool:
        """Whether any panel text this page received contains ``text``."""
        return any(text in str(update["updates"].get("content", ""))
                   for update in self.updates)
