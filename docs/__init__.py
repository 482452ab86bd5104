"""The documentation pages, installed with rigval so that ``rigval docs TOPIC`` can print them.

This folder holds Markdown pages only; it is a package so that the wheel carries the pages as
package data (``rigval.docs``).
"""
