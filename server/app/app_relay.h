/* app: the edge relay (strandcastd --relay --nats URL): serves the page, /metrics and WebSockets
 * for any room; each client's open, text and close go to its room's simulation node over NATS
 * (text only within the client's control-message budget and when it parses: else the edge
 * answers the error itself, as a daemon would),
 * what the node sends back (hello, replies with their ids, announcements, closes) goes to the
 * client, and each stream a client here uses is subscribed once and fed to the same net
 * delivery as the daemon's own (newest frame, bounded memory, slow clients skip). A node silent
 * for BUS_BEAT_TIMEOUT_MS gets its clients here an error room_unavailable and close 4503. */
#ifndef APP_RELAY_H
#define APP_RELAY_H

#include "app.h"

/* Runs the edge on the calling thread until SIGINT/SIGTERM (as app_run). desc: nats (required),
 * nats_creds, listen, port, web_dir, client_buffer, max_clients, ping_*, allow_origins, tls_*.
 * CORE_OK after a clean shutdown, or the error that stopped start-up. */
core_status app_relay_run(const app_desc *desc, core_err *err);

#endif
