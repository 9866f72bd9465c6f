//! The compensation pass. (Being written.)
