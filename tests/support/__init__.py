"""Test helpers shared by the test modules (test modules never import each other): `from tests.support.x import y`."""
