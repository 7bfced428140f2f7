//! Typed indices into a [`Net`](crate::Net)'s element tables, so a place index can never be
//! used where a transition index is meant.

use std::fmt;

macro_rules! index_type {
    ($(#[$doc:meta])* $name:ident, $prefix:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $name(pub u32);

        impl $name {
            /// The position in the net's table.
            #[inline]
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }

        impl From<usize> for $name {
            #[inline]
            fn from(i: usize) -> Self {
                $name(u32::try_from(i).expect(concat!(stringify!($name), " overflows u32")))
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, concat!($prefix, "{}"), self.0)
            }
        }
    };
}

index_type!(
    /// A place, by its position in declaration order.
    PlaceId,
    "p#"
);
index_type!(
    /// A transition, by its position in declaration order; the lower index has priority.
    TransitionId,
    "t#"
);
index_type!(
    /// An arc, by its position in declaration order.
    ArcId,
    "a#"
);
index_type!(
    /// An input or output signal.
    SignalId,
    "s#"
);
