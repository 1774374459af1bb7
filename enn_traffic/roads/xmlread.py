"""Reading SUMO's XML files in large blocks.

Python's readers feed expat 16 KiB (ElementTree.iterparse) or 64 KiB (xml.sax, which sumolib's
network reader uses without lxml) at a time, and expat before 2.6 parses a token cut by a
block's end again at every block (CVE-2023-52425): a long comment or attribute then costs time
quadratic in its length (a network with a 16 MB comment took sumolib 1.3 s, one of 64 MB
about 20 s; the well-formedness check took 78 s). Fed :data:`XML_BLOCK` bytes at a time, such a
token is parsed again a few times at most.
"""

from __future__ import annotations

import gzip
import os
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO
from xml.sax.expatreader import ExpatParser

import sumolib

XML_BLOCK = 16 << 20  # bytes fed to the XML parser at a time
GZIP_MAGIC = b"\x1f\x8b"


def iterparse(source: str | os.PathLike | BinaryIO, events: tuple[str, ...] = ("end",)
              ) -> Iterator[tuple[str, ElementTree.Element]]:
    """:func:`xml.etree.ElementTree.iterparse` of ``source`` (a path, or a file opened in
    binary), fed :data:`XML_BLOCK` bytes at a time."""
    parser = ElementTree.XMLPullParser(events=events)
    owned = isinstance(source, (str, os.PathLike))
    handle = open(source, "rb") if owned else source  # noqa: SIM115 (closed below)
    try:
        for block in iter(lambda: handle.read(XML_BLOCK), b""):
            parser.feed(block)
            yield from parser.read_events()
        parser.close()
        yield from parser.read_events()
    finally:
        if owned:
            handle.close()


def parse_root(source: str | os.PathLike | BinaryIO) -> ElementTree.Element:
    """The root element of the XML file ``source`` (a path, or a file opened in binary), the
    whole tree under it, read by :func:`iterparse` (:func:`xml.etree.ElementTree.parse`
    feeds 64 KiB at a time)."""
    events = iterparse(source, ("start",))
    _, root = next(events)
    for _ in events:  # the rest of the tree, kept under the root
        pass
    return root


def open_xml(path: Path) -> BinaryIO:
    """``path`` opened in binary, through gzip when its first bytes say it is compressed (as
    SUMO and sumolib tell, whatever its name)."""
    with open(path, "rb") as handle:
        compressed = handle.read(2) == GZIP_MAGIC
    return gzip.open(path, "rb") if compressed else open(path, "rb")  # noqa: SIM115


def read_sumo_net(path: Path, **options) -> sumolib.net.Net:
    """:func:`sumolib.net.readNet` (``options`` are its own: ``withInternal`` ...) through
    its xml.sax reader, fed :data:`XML_BLOCK` bytes at a time."""
    reader = sumolib.net.NetReader(**options)
    parser = ExpatParser(bufsize=XML_BLOCK)
    parser.setContentHandler(reader)
    with open_xml(path) as handle:
        parser.parse(handle)
    return reader.getNet()
