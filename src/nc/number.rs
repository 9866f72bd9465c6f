//! Numbers as programs write them.
