//! Stratified direction layouts for hemisphere and sphere gathers, and irradiance with its
//! derivatives from what the traced rays found.
