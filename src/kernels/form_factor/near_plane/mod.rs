//! `x` near the polygon's plane: the near-plane split and the routes that replay it without the
//! robust path's set-up.

pub(crate) mod clipped_loop;
pub(crate) mod far_piece;
pub(crate) mod polygon;
pub(crate) mod route_loop;
pub(crate) mod split;
pub(crate) mod triangle;
