"""A Python child script with a syntax error on line 4."""


def broken(:
    return []
