//! Debug images (filled in below).
