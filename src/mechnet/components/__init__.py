"""Component libraries, one subpackage per physical domain."""
