//! The machinery that turns the one declaration of the protocol (in [`crate::protocol`]) into
//! everything each request needs: its [`Request`](crate::Request) variant, its endpoint type
//! and [`Endpoint`](crate::protocol::Endpoint) impl, its name, which answer pairs with it, its
//! piece of the schema text ([`crate::SCHEMA`]) and its arm in the adapter's typed
//! [`dispatch`](crate::protocol::dispatch).
//!
//! Before this, adding a request meant writing it in eight places (the enum, the endpoint
//! struct, its impl, `Request::name`, `Request::is_answered_by`, the schema text, the golden
//! test and the adapter's `handle` match), each a chance to disagree with the others. Now a
//! request is one line of the declaration (its index, name, payload and the
//! [`Response`](crate::Response) variant that answers it), one
//! [`Answer`](crate::protocol::Answer) impl in the adapter (the adapter does not build without
//! it) and its golden encoding in the tests.
//!
//! The byte layout is postcard's of the generated enums, exactly as when they were written by
//! hand: the macro writes the variants out in the declared order, and a compile-time check
//! refuses an index out of order (postcard's tag is the variant's position).

/// How one variant of [`Request`](crate::Request) or [`Response`](crate::Response) is shown
/// in the schema text: `Name`, `Name(Type)` or `Name{field:type, ...}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VariantSchema {
    /// The declared variant index (postcard's varint tag).
    pub index: u32,
    /// The variant's name.
    pub name: &'static str,
    /// What it carries.
    pub payload: PayloadSchema,
}

/// What a variant carries, as the schema text names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PayloadSchema {
    /// Nothing.
    Unit,
    /// One value of the named type.
    Newtype(&'static str),
    /// Named fields and their types, in order.
    Fields(&'static [(&'static str, &'static str)]),
}

/// True when every variant's declared index is its position (postcard's tag is the
/// position, so a declared index that differs would be a lie in the schema text).
pub const fn indices_in_order(variants: &[VariantSchema]) -> bool {
    let mut i = 0;
    while i < variants.len() {
        if variants[i].index as usize != i {
            return false;
        }
        i += 1;
    }
    true
}

/// Declares the protocol: `Request` and `Response`, one endpoint type per request (in an
/// `endpoints` module), one reply kind per response (in `replies`), `Request::name`,
/// `Request::expects`, the variants' schema (`Request::VARIANTS`, `Response::VARIANTS`), the
/// `Serve` trait (an `Answer` for every request, and a gate) and `dispatch`.
///
/// A request is `INDEX Name -> Reply,` with an optional payload between the name and the
/// arrow: `(Type)` (a type name in scope) or `{ field: type, ... }`; `Reply` names the
/// `Response` variant that answers it; `async` after it marks a request whose answer waits
/// (the adapter writes its flash first): it is answered by an `AnswerAsync`, the others by an
/// `Answer` at once (an await per request would cost the firmware flash and RAM for nothing). A response is `INDEX Name,` with nothing, `(Type)` or
/// one named field `{ field: type }`. Doc comments go on variants and fields as usual.
/// Neither a request nor a response may be named like a type its payload uses.
///
/// The expansion names, unqualified, what the invoking module defines beside it (as
/// [`crate::protocol`] does): the traits `Endpoint`, `ReplyKind`, `Answer` and `AnswerAsync`,
/// the function `respond`, `ErrorCode` and the payload types.
macro_rules! wire_protocol {
    // Yields its first token: lets an optional group that carries a metavariable emit a
    // fixed binding name instead of it.
    (@first $x:tt $($ignored:tt)*) => { $x };

    // The endpoint type of one request, shaped like its variant.
    (@endpoint $V:ident) => {
        #[doc = concat!("[`Request::", stringify!($V), "`] as a type: its endpoint.")]
        #[derive(Debug, Clone, PartialEq)]
        pub struct $V;
    };
    (@endpoint $V:ident ($P:ident)) => {
        #[doc = concat!("[`Request::", stringify!($V), "`] as a type: its endpoint.")]
        #[derive(Debug, Clone, PartialEq)]
        pub struct $V(pub super::$P);
    };
    (@endpoint $V:ident { $( [$($fa:tt)*] $f:ident : $t:ty ),* }) => {
        #[doc = concat!("[`Request::", stringify!($V), "`] as a type: its endpoint.")]
        #[derive(Debug, Clone, PartialEq)]
        pub struct $V { $( $($fa)* pub $f: $t ),* }
    };

    // The reply kind of one response variant.
    (@reply $V:ident) => {
        #[doc = concat!("[`Response::", stringify!($V), "`], carrying nothing.")]
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub struct $V;
        impl super::ReplyKind for $V {
            type Value = ();
            fn is(response: &Response) -> bool {
                matches!(response, Response::$V)
            }
            fn take(response: &Response) -> Option<()> {
                match response {
                    Response::$V => Some(()),
                    _ => None,
                }
            }
            fn wrap(_: ()) -> Response {
                Response::$V
            }
        }
    };
    (@reply $V:ident ($P:ident)) => {
        #[doc = concat!("[`Response::", stringify!($V), "`], carrying a [`", stringify!($P), "`](super::", stringify!($P), ").")]
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub struct $V;
        impl super::ReplyKind for $V {
            type Value = super::$P;
            fn is(response: &Response) -> bool {
                matches!(response, Response::$V(_))
            }
            fn take(response: &Response) -> Option<super::$P> {
                match response {
                    Response::$V(value) => Some(Clone::clone(value)),
                    _ => None,
                }
            }
            fn wrap(value: super::$P) -> Response {
                Response::$V(value)
            }
        }
    };
    (@reply $V:ident { $f:ident : $t:ty }) => {
        #[doc = concat!("[`Response::", stringify!($V), "`], carrying its `", stringify!($f), "`.")]
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub struct $V;
        impl super::ReplyKind for $V {
            type Value = $t;
            fn is(response: &Response) -> bool {
                matches!(response, Response::$V { .. })
            }
            fn take(response: &Response) -> Option<$t> {
                match response {
                    Response::$V { $f } => Some(Clone::clone($f)),
                    _ => None,
                }
            }
            fn wrap($f: $t) -> Response {
                Response::$V { $f }
            }
        }
    };

    // `Serve`: an `Answer` (or, for a request declared `async`, an `AnswerAsync`) for each
    // request, its bounds gathered one request at a time.
    (@serve [$($bounds:tt)*]) => {
        /// What [`dispatch`] serves: an [`Answer`] (an [`AnswerAsync`] for a request declared
        /// `async`) for each type in [`endpoints`] (a server without one does not compile),
        /// and the gate in front of them.
        pub trait Serve: $($bounds)* {
            /// `request` back when it may be answered; `Err(code)`: it is refused with `code`
            /// before its answer is asked (the adapter refuses everything but `Hello` outside a
            /// session). By value: a borrow would keep a second copy of the request in
            /// [`dispatch`]'s future across its awaits (284 B of the firmware's static RAM).
            fn admit(&self, request: Request) -> Result<Request, ErrorCode>;
        }
    };
    (@serve [$($bounds:tt)*] $V:ident async, $($rest:tt)*) => {
        $crate::declare::wire_protocol!(@serve [$($bounds)* AnswerAsync<endpoints::$V> +] $($rest)*);
    };
    (@serve [$($bounds:tt)*] $V:ident, $($rest:tt)*) => {
        $crate::declare::wire_protocol!(@serve [$($bounds)* Answer<endpoints::$V> +] $($rest)*);
    };

    // One request's answer inside `dispatch`: called at once, or awaited when declared `async`.
    (@answer $S:ident $server:ident $endpoint:ident $V:ident) => {
        <$S as Answer<endpoints::$V>>::answer($server, $endpoint)
    };
    (@answer $S:ident $server:ident $endpoint:ident $V:ident async) => {
        <$S as AnswerAsync<endpoints::$V>>::answer($server, $endpoint).await
    };

    // One variant's schema.
    (@schema) => { $crate::declare::PayloadSchema::Unit };
    (@schema ($P:ident)) => { $crate::declare::PayloadSchema::Newtype(stringify!($P)) };
    (@schema { $( $f:ident : $t:ty ),* }) => {
        $crate::declare::PayloadSchema::Fields(&[ $( (stringify!($f), stringify!($t)) ),* ])
    };

    (
        $(#[$req_attr:meta])*
        pub enum Request {
            $(
                $(#[$rm:meta])*
                $ri:literal $RV:ident
                $( ( $RP:ident ) )?
                $( { $( $(#[$rfm:meta])* $rf:ident : $rft:ty ),* $(,)? } )?
                -> $Reply:ident $( $wait:ident )?
            ),* $(,)?
        }

        $(#[$resp_attr:meta])*
        pub enum Response {
            $(
                $(#[$sm:meta])*
                $si:literal $SV:ident
                $( ( $SP:ident ) )?
                $( { $(#[$sfm:meta])* $sf:ident : $sft:ty $(,)? } )?
            ),* $(,)?
        }
    ) => {
        $(#[$req_attr])*
        pub enum Request {
            $(
                $(#[$rm])*
                $RV $( ($RP) )? $( { $( $(#[$rfm])* $rf: $rft ),* } )?,
            )*
        }

        $(#[$resp_attr])*
        pub enum Response {
            $(
                $(#[$sm])*
                $SV $( ($SP) )? $( { $(#[$sfm])* $sf: $sft } )?,
            )*
        }

        /// One type per [`Request`] variant, shaped like it (its endpoint): what a client
        /// sends with `call` and what the adapter's [`Answer`] impls take.
        pub mod endpoints {
            use super::*;
            $(
                $crate::declare::wire_protocol!(@endpoint $RV $( ($RP) )?
                    $( { $( [$(#[$rfm])*] $rf : $rft ),* } )?);

                impl super::Endpoint for $RV {
                    const NAME: &'static str = stringify!($RV);
                    type Reply = <super::replies::$Reply as super::ReplyKind>::Value;
                    type Kind = super::replies::$Reply;
                    fn request(&self) -> Request {
                        Request::$RV
                            $( ($crate::declare::wire_protocol!(@first {Clone::clone(&self.0)} $RP)) )?
                            $( { $( $rf: Clone::clone(&self.$rf) ),* } )?
                    }
                }
            )*
        }

        /// One type per [`Response`] variant (its reply kind): what an [`Endpoint`] names as
        /// its answer.
        pub mod replies {
            use super::*;
            $(
                $crate::declare::wire_protocol!(@reply $SV $( ($SP) )? $( { $sf : $sft } )?);
            )*
        }

        impl Request {
            /// The request's name (its [`Endpoint::NAME`]), for messages.
            pub const fn name(&self) -> &'static str {
                match self {
                    $( Request::$RV { .. } => stringify!($RV), )*
                }
            }

            /// True when `response` is this request's success answer (its endpoint's reply
            /// kind); [`Request::is_answered_by`] adds the errors.
            pub fn expects(&self, response: &Response) -> bool {
                match self {
                    $(
                        Request::$RV { .. } => <replies::$Reply as ReplyKind>::is(response),
                    )*
                }
            }

            /// The variants as the schema text shows them, in order.
            pub const VARIANTS: &'static [$crate::declare::VariantSchema] = &[
                $(
                    $crate::declare::VariantSchema {
                        index: $ri,
                        name: stringify!($RV),
                        payload: $crate::declare::wire_protocol!(@schema $( ($RP) )?
                            $( { $( $rf : $rft ),* } )?),
                    },
                )*
            ];
        }

        impl Response {
            /// The variants as the schema text shows them, in order.
            pub const VARIANTS: &'static [$crate::declare::VariantSchema] = &[
                $(
                    $crate::declare::VariantSchema {
                        index: $si,
                        name: stringify!($SV),
                        payload: $crate::declare::wire_protocol!(@schema $( ($SP) )?
                            $( { $sf : $sft } )?),
                    },
                )*
            ];
        }

        const _: () = assert!(
            $crate::declare::indices_in_order(Request::VARIANTS)
                && $crate::declare::indices_in_order(Response::VARIANTS),
            "a declared variant index is not its position (postcard's tag)"
        );

        $crate::declare::wire_protocol!(@serve [] $( $RV $($wait)?, )*);

        /// Hands `request`, once `server` admits it, to `server`'s answer for its endpoint
        /// and wraps the typed reply (or the error code) in its [`Response`]: the adapter
        /// cannot answer a request with a response of another kind.
        pub async fn dispatch<S: Serve>(server: &mut S, request: Request) -> Response {
            match server.admit(request) {
                Err(code) => Response::Error(code),
                $(
                    Ok(Request::$RV
                        $( ($crate::declare::wire_protocol!(@first payload $RP)) )?
                        $( { $( $rf ),* } )?)
                    => {
                        let endpoint = endpoints::$RV
                            $( ($crate::declare::wire_protocol!(@first payload $RP)) )?
                            $( { $( $rf ),* } )?;
                        respond::<endpoints::$RV>($crate::declare::wire_protocol!(
                            @answer S server endpoint $RV $($wait)?
                        ))
                    }
                )*
            }
        }
    };
}

pub(crate) use wire_protocol;
