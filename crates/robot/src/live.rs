//! The live view: the log's channels, and the GNSS position as `foxglove.LocationFix` on
//! [`LOCATION_TOPIC`], served over the Foxglove WebSocket protocol (`[foxglove] listen`).
//!
//! The logger thread owns the [`LiveView`] and feeds it what it writes to the log, as the log
//! writer's tap ([`LiveTap`]): every channel as it is declared ([`LiveView::add_channel`], the
//! same topic, schema and encodings as in the MCAP file) and every message as it is written
//! ([`LiveView::publish`]), plus each new GNSS fix ([`LiveView::location`]). The realtime thread never sees it.
//!
//! The server runs on its own runtime (one worker thread, `dima-live`). Publishing never waits
//! for a client: a message is only copied into each subscribed client's outbox, a bounded
//! queue ([`CLIENT_BACKLOG`] messages) whose oldest message is dropped when a slow or stuck
//! client lets it fill; no message is encoded when nobody subscribed to its channel.
//!
//! Built without the `foxglove` feature, [`LiveView::start`] fails with an error that says
//! so, and the rest of the API is there but does nothing.

use std::net::SocketAddr;

use crate::app::record::CycleRecord;

/// Topic of the GNSS position (`foxglove.LocationFix`, for Foxglove's Map panel).
pub const LOCATION_TOPIC: &str = "/dima/location";

/// Messages each client's outbox holds before the oldest is dropped (about 2 s of the
/// default 250 Hz loop's cycle, raw-packet and location messages).
pub const CLIENT_BACKLOG: usize = 1_024;

/// One GNSS fix for [`LiveView::location`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Location {
    /// Latitude, degrees.
    pub latitude_deg: f64,
    /// Longitude, degrees.
    pub longitude_deg: f64,
    /// Height above the ellipsoid, m.
    pub altitude_m: f64,
    /// Horizontal accuracy estimate (one sigma), m; `None`: unknown.
    pub horizontal_accuracy_m: Option<f64>,
    /// Vertical accuracy estimate (one sigma), m; `None`: unknown.
    pub vertical_accuracy_m: Option<f64>,
}

impl Location {
    /// The fix of a u-blox NAV-PVT solution, its accuracy estimates included.
    pub fn from_nav_pvt(pvt: &dima_sensorboard::NavPvt) -> Location {
        Location {
            latitude_deg: pvt.lat_deg(),
            longitude_deg: pvt.lon_deg(),
            altitude_m: f64::from(pvt.height_mm) / 1e3,
            horizontal_accuracy_m: Some(f64::from(pvt.h_acc_mm) / 1e3),
            vertical_accuracy_m: Some(f64::from(pvt.v_acc_mm) / 1e3),
        }
    }

    /// The ENU position covariance (m², row-major 3x3, diagonal: east and north from the
    /// horizontal accuracy, up from the vertical one); `None` unless both are known.
    pub fn covariance(&self) -> Option<[f64; 9]> {
        let (h, v) = (self.horizontal_accuracy_m?, self.vertical_accuracy_m?);
        let mut c = [0.0; 9];
        c[0] = h * h;
        c[4] = h * h;
        c[8] = v * v;
        Some(c)
    }
}

/// The new GNSS fix a cycle used, if any.
pub fn new_fix(r: &CycleRecord) -> Option<Location> {
    if !r.outputs.gnss_new {
        return None;
    }
    let pvt = r.outputs.packet.as_ref()?.nav_pvt()?;
    Some(Location::from_nav_pvt(&pvt))
}

#[cfg(feature = "foxglove")]
mod server {
    use std::collections::BTreeMap;
    use std::net::SocketAddr;
    use std::sync::{Arc, Mutex, PoisonError};

    use anyhow::Context as _;
    use foxglove::messages::location_fix::PositionCovarianceType;
    use foxglove::messages::{LocationFix, Timestamp};
    use foxglove::{Channel, ChannelBuilder, Context, PartialMetadata, RawChannel, Schema};

    use super::{Location, CLIENT_BACKLOG, LOCATION_TOPIC};

    /// The running server and its channels.
    pub struct Server {
        runtime: Option<tokio::runtime::Runtime>,
        handle: Option<foxglove::WebSocketServerHandle>,
        context: Arc<Context>,
        local: SocketAddr,
        /// By the caller's channel id (only the logger thread locks it).
        channels: Mutex<BTreeMap<u16, Arc<RawChannel>>>,
        location: Channel<LocationFix>,
    }

    impl Server {
        pub fn start(addr: SocketAddr) -> anyhow::Result<Server> {
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(1)
                .thread_name("dima-live")
                .enable_all()
                .build()
                .context("live view: starting its runtime")?;
            let context = Context::new();
            let handle = context
                .websocket_server()
                .name(format!("dima {}", env!("CARGO_PKG_VERSION")))
                .bind(addr.ip().to_string(), addr.port())
                .message_backlog_size(CLIENT_BACKLOG)
                .tokio_runtime(runtime.handle())
                .start_blocking()
                .with_context(|| format!("live view: cannot listen on {addr}"))?;
            let local = SocketAddr::new(addr.ip(), handle.port());
            let location = ChannelBuilder::new(LOCATION_TOPIC)
                .context(&context)
                .build::<LocationFix>();
            Ok(Server {
                runtime: Some(runtime),
                handle: Some(handle),
                context,
                local,
                channels: Mutex::new(BTreeMap::new()),
                location,
            })
        }

        pub fn local_addr(&self) -> SocketAddr {
            self.local
        }

        fn channels(&self) -> std::sync::MutexGuard<'_, BTreeMap<u16, Arc<RawChannel>>> {
            self.channels.lock().unwrap_or_else(PoisonError::into_inner)
        }

        pub fn add_channel(
            &self,
            id: u16,
            topic: &str,
            schema_name: &str,
            schema_encoding: &str,
            schema: &[u8],
            message_encoding: &str,
        ) {
            let mut channels = self.channels();
            if channels.contains_key(&id) {
                return;
            }
            let schema = (!schema_name.is_empty() || !schema.is_empty())
                .then(|| Schema::new(schema_name, schema_encoding, schema.to_vec()));
            let built = ChannelBuilder::new(topic)
                .context(&self.context)
                .message_encoding(message_encoding)
                .schema(schema)
                .build_raw();
            match built {
                Ok(channel) => {
                    channels.insert(id, channel);
                }
                Err(e) => tracing::warn!("live view: channel {topic} not served: {e}"),
            }
        }

        pub fn publish(&self, id: u16, log_time_ns: u64, data: &[u8]) {
            if let Some(channel) = self.channels().get(&id) {
                channel.log_with_meta(data, PartialMetadata::with_log_time(log_time_ns));
            }
        }

        pub fn location(&self, log_time_ns: u64, fix: &Location) {
            if !self.location.has_sinks() {
                return;
            }
            let (covariance, kind) = match fix.covariance() {
                Some(c) => (c.to_vec(), PositionCovarianceType::DiagonalKnown),
                None => (Vec::new(), PositionCovarianceType::Unknown),
            };
            let message = LocationFix {
                timestamp: Some(Timestamp::new(
                    (log_time_ns / 1_000_000_000) as u32,
                    (log_time_ns % 1_000_000_000) as u32,
                )),
                frame_id: "gnss".to_owned(),
                latitude: fix.latitude_deg,
                longitude: fix.longitude_deg,
                altitude: fix.altitude_m,
                position_covariance: covariance,
                position_covariance_type: kind as i32,
                ..LocationFix::default()
            };
            self.location.log_with_time(&message, log_time_ns);
        }
    }

    impl Drop for Server {
        fn drop(&mut self) {
            // Stops listening; the client tasks are aborted with the runtime, which does not
            // wait for them.
            if let Some(handle) = self.handle.take() {
                drop(handle.stop());
            }
            if let Some(runtime) = self.runtime.take() {
                runtime.shutdown_background();
            }
        }
    }
}

/// The live view's server and its channels (see the module documentation).
pub struct LiveView {
    #[cfg(feature = "foxglove")]
    server: server::Server,
}

impl LiveView {
    /// Starts the server on `addr` (port 0: a free port, see [`LiveView::local_addr`]). Fails
    /// when the address cannot be bound, or when the program was built without the `foxglove`
    /// feature.
    pub fn start(addr: SocketAddr) -> anyhow::Result<LiveView> {
        #[cfg(feature = "foxglove")]
        {
            Ok(LiveView {
                server: server::Server::start(addr)?,
            })
        }
        #[cfg(not(feature = "foxglove"))]
        {
            anyhow::bail!(
                "live view on {addr} ([foxglove] listen): this program was built without the \
                 `foxglove` feature"
            )
        }
    }

    /// The address the server listens on.
    pub fn local_addr(&self) -> SocketAddr {
        #[cfg(feature = "foxglove")]
        {
            self.server.local_addr()
        }
        #[cfg(not(feature = "foxglove"))]
        {
            unreachable!("a LiveView cannot be started without the foxglove feature")
        }
    }

    /// Serves a channel of the log: `id` is the log's channel id, by which
    /// [`LiveView::publish`] names it. Registering an id again (a log continued in its next
    /// file) changes nothing. An empty `schema_name` and `schema`: a channel without schema.
    pub fn add_channel(
        &self,
        id: u16,
        topic: &str,
        schema_name: &str,
        schema_encoding: &str,
        schema: &[u8],
        message_encoding: &str,
    ) {
        #[cfg(feature = "foxglove")]
        self.server.add_channel(
            id,
            topic,
            schema_name,
            schema_encoding,
            schema,
            message_encoding,
        );
        #[cfg(not(feature = "foxglove"))]
        let _ = (
            id,
            topic,
            schema_name,
            schema_encoding,
            schema,
            message_encoding,
        );
    }

    /// Sends a message of channel `id` to the clients subscribed to it, without waiting for
    /// any of them; `log_time_ns` is its log time (ns since the Unix epoch).
    pub fn publish(&self, id: u16, log_time_ns: u64, data: &[u8]) {
        #[cfg(feature = "foxglove")]
        self.server.publish(id, log_time_ns, data);
        #[cfg(not(feature = "foxglove"))]
        let _ = (id, log_time_ns, data);
    }

    /// Sends the new GNSS fix of cycle record `r`, if it carries one, as [`LiveView::location`]
    /// at `log_time_ns`.
    pub fn cycle(&self, r: &CycleRecord, log_time_ns: u64) {
        if let Some(fix) = new_fix(r) {
            self.location(log_time_ns, &fix);
        }
    }

    /// Sends a GNSS fix as `foxglove.LocationFix` on [`LOCATION_TOPIC`], as [`LiveView::publish`].
    pub fn location(&self, log_time_ns: u64, fix: &Location) {
        #[cfg(feature = "foxglove")]
        self.server.location(log_time_ns, fix);
        #[cfg(not(feature = "foxglove"))]
        let _ = (log_time_ns, fix);
    }
}

/// The live view as the log writer's tap (`dima_log::writer::Tap`): every channel the writer
/// declares and every message it writes, in the logger thread, in every file of the run.
pub struct LiveTap(pub std::sync::Arc<LiveView>);

impl dima_log::writer::Tap for LiveTap {
    fn channel(
        &mut self,
        id: u16,
        topic: &str,
        schema_name: &str,
        schema_encoding: &str,
        schema: &[u8],
        message_encoding: &str,
    ) {
        self.0.add_channel(
            id,
            topic,
            schema_name,
            schema_encoding,
            schema,
            message_encoding,
        );
    }

    fn message(&mut self, channel_id: u16, log_time_ns: u64, data: &[u8]) {
        self.0.publish(channel_id, log_time_ns, data);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_covariance_comes_from_both_accuracies_or_not_at_all() {
        let mut fix = Location {
            latitude_deg: -34.0885,
            longitude_deg: 18.475,
            altitude_m: 44.0,
            horizontal_accuracy_m: Some(1.5),
            vertical_accuracy_m: Some(2.5),
        };
        let c = fix.covariance().unwrap();
        assert_eq!((c[0], c[4], c[8]), (2.25, 2.25, 6.25));
        assert_eq!(c.iter().filter(|&&v| v != 0.0).count(), 3, "{c:?}");
        fix.vertical_accuracy_m = None;
        assert_eq!(fix.covariance(), None);
    }

    #[cfg(feature = "foxglove")]
    mod stuck_client {
        use std::io::{Read, Write};
        use std::net::TcpStream;
        use std::os::fd::AsRawFd;
        use std::time::{Duration, Instant};

        use super::super::*;

        /// One frame from the server (unmasked): opcode and payload.
        fn read_frame(s: &mut TcpStream) -> (u8, Vec<u8>) {
            let mut head = [0u8; 2];
            s.read_exact(&mut head).unwrap();
            let len = match head[1] & 0x7F {
                126 => {
                    let mut b = [0u8; 2];
                    s.read_exact(&mut b).unwrap();
                    u64::from(u16::from_be_bytes(b))
                }
                127 => {
                    let mut b = [0u8; 8];
                    s.read_exact(&mut b).unwrap();
                    u64::from_be_bytes(b)
                }
                n => u64::from(n),
            };
            let mut payload = vec![0u8; len as usize];
            s.read_exact(&mut payload).unwrap();
            (head[0] & 0x0F, payload)
        }

        /// A masked text frame from the client (payload under 126 bytes).
        fn text_frame(text: &str) -> Vec<u8> {
            let mask = [1u8, 2, 3, 4];
            let mut f = vec![0x81, 0x80 | text.len() as u8];
            f.extend_from_slice(&mask);
            f.extend(text.bytes().enumerate().map(|(i, b)| b ^ mask[i % 4]));
            f
        }

        /// A client that subscribes to the channel, reads one message, then never reads
        /// again (its socket's receive buffer as small as the kernel allows).
        fn stuck_client(addr: std::net::SocketAddr, live: &LiveView) -> TcpStream {
            let mut s = TcpStream::connect(addr).unwrap();
            // Every read of the handshake is bounded: a server that never answers fails the
            // test instead of hanging it.
            s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
            let small: libc::c_int = 1;
            // SAFETY: a valid socket and a c_int option of the right size.
            unsafe {
                libc::setsockopt(
                    s.as_raw_fd(),
                    libc::SOL_SOCKET,
                    libc::SO_RCVBUF,
                    (&small as *const libc::c_int).cast(),
                    std::mem::size_of::<libc::c_int>() as libc::socklen_t,
                );
            }
            write!(
                s,
                "GET / HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
                 Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\
                 Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
            )
            .unwrap();
            let mut response = Vec::new();
            while !response.ends_with(b"\r\n\r\n") {
                let mut b = [0u8; 1];
                s.read_exact(&mut b).unwrap();
                response.push(b[0]);
            }
            assert!(response.starts_with(b"HTTP/1.1 101"), "{response:?}");
            let channel_id = loop {
                let (opcode, payload) = read_frame(&mut s);
                if opcode != 1 {
                    continue;
                }
                let v: serde_json::Value = serde_json::from_slice(&payload).unwrap();
                if v["op"] != "advertise" {
                    continue;
                }
                // The server also serves `/dima/location`, and the advertisement lists the
                // channels in no fixed order: take the test's own by its topic.
                let ours = v["channels"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .find(|c| c["topic"] == "/test");
                if let Some(channel) = ours {
                    break channel["id"].as_u64().unwrap();
                }
            };
            s.write_all(&text_frame(&format!(
                r#"{{"op":"subscribe","subscriptions":[{{"id":7,"channelId":{channel_id}}}]}}"#
            )))
            .unwrap();
            // Subscribed once a message arrives: one message published and at most one whole
            // frame read per round, so nothing piles up in the client's outbox while it waits
            // (a byte-wise scan could take a JSON byte for a binary frame's head).
            let deadline = Instant::now() + Duration::from_secs(60);
            loop {
                assert!(
                    Instant::now() < deadline,
                    "no message within 60 s of subscribing"
                );
                live.publish(1, 1, b"{}");
                s.set_read_timeout(Some(Duration::from_millis(100)))
                    .unwrap();
                let mut first = [0u8; 1];
                let waiting = s.peek(&mut first);
                s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
                match waiting {
                    Ok(0) => panic!("the server closed the connection"),
                    Ok(_) => {
                        if read_frame(&mut s).0 == 2 {
                            break;
                        }
                    }
                    Err(_) => {}
                }
            }
            s
        }

        #[test]
        fn a_client_that_stops_reading_never_holds_up_publishing() {
            let live =
                std::sync::Arc::new(LiveView::start("127.0.0.1:0".parse().unwrap()).unwrap());
            live.add_channel(1, "/test", "", "", b"", "json");
            let _client = stuck_client(live.local_addr(), &live);
            // Far more than the socket buffers and the client's outbox hold: were publishing
            // to wait for the client, it would never finish.
            let (done_tx, done) = std::sync::mpsc::channel();
            let publisher = std::sync::Arc::clone(&live);
            std::thread::spawn(move || {
                let data = vec![b' '; 16 * 1024];
                let t0 = Instant::now();
                let mut slowest = Duration::ZERO;
                for i in 0..20_000u64 {
                    let t = Instant::now();
                    publisher.publish(1, i, &data);
                    slowest = slowest.max(t.elapsed());
                }
                let _ = done_tx.send((t0.elapsed(), slowest));
            });
            let (total, slowest) = done
                .recv_timeout(Duration::from_secs(120))
                .expect("publishing waits for a client that does not read");
            eprintln!("20000 publishes of 16 KiB, a client stuck: {total:?}, slowest {slowest:?}");
        }
    }
}
