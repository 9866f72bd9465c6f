//! ISO 230 error names. (Being written.)
