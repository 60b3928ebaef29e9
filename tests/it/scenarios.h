/* The integration scenarios, listed once: it_main.c makes its cmocka table from this list and
 * tests/integration.cmake one ctest test per line (integration_NAME, with the timeout in
 * seconds and the space-separated ctest labels). IT_SCENARIO(name, setup, teardown, timeout,
 * "labels"): test_NAME runs between the two (NULL: none; the state is then the config).
 * "no_asan": the release tree only (timing bounds, or lavapipe, whose allocations LeakSanitizer
 * reports); "serial": a timing bound, so ctest runs nothing beside it. Keep one entry per line,
 * in this form. */
IT_SCENARIO(hello_and_frames, setup, teardown, 120, "integration")
IT_SCENARIO(params_broadcast_and_physics, setup, teardown, 120, "integration")
IT_SCENARIO(motion_moves_roots, setup, teardown, 120, "integration")
IT_SCENARIO(bad_inputs_keep_stream, setup, teardown, 120, "integration")
IT_SCENARIO(subprotocol_refused, setup, teardown, 120, "integration")
IT_SCENARIO(close_frames_and_methods, setup, teardown, 120, "integration")
IT_SCENARIO(http_static_and_metrics, setup, teardown, 120, "integration")
IT_SCENARIO(pause_step_subscribe_groom, setup, teardown, 120, "integration")
IT_SCENARIO(slow_client_skips, setup, teardown, 120, "integration")
IT_SCENARIO(rate_streams, setup, teardown, 120, "integration")
IT_SCENARIO(stream_slots, setup, teardown, 120, "integration")
IT_SCENARIO(hairmesh_source_refused, setup, teardown, 60, "integration")
IT_SCENARIO(cli_client, setup, teardown, 120, "integration")
IT_SCENARIO(wsc_http_get, setup, teardown, 120, "integration")
IT_SCENARIO(wsc_http_get_chunked, setup, teardown, 120, "integration")
IT_SCENARIO(stream_failure_is_reported, setup, teardown, 120, "integration")
IT_SCENARIO(flood_spares_others, setup, teardown, 120, "integration")
IT_SCENARIO(groom_change_keeps_frames, setup_auto, teardown, 120, "integration no_asan serial")
IT_SCENARIO(sigterm_closes_clients, setup, teardown, 120, "integration")
IT_SCENARIO(sigint_closes_clients, setup, teardown, 120, "integration")
IT_SCENARIO(listen_ipv6, setup_ipv6, teardown, 120, "integration")
IT_SCENARIO(default_address, NULL, NULL, 120, "integration")
IT_SCENARIO(flags, NULL, NULL, 120, "integration")
IT_SCENARIO(reader_that_never_reads_is_closed, setup, teardown, 120, "integration")
IT_SCENARIO(groom_budget_refuses, setup_budget, teardown, 120, "integration")
IT_SCENARIO(max_clients_refused, setup_two_clients, teardown, 120, "integration")
IT_SCENARIO(large_groom_hello_small, setup_large_groom, teardown, 300, "integration")
IT_SCENARIO(token_makes_writers, setup_token, teardown, 120, "integration")
IT_SCENARIO(origin_refused, setup_origin, teardown, 120, "integration")
IT_SCENARIO(tls_serves_wss, setup_tls, teardown, 120, "integration")
IT_SCENARIO(ping_drops_silent_client, setup_ping, teardown, 120, "integration")
IT_SCENARIO(collider_mesh, setup_ratboy, teardown_ratboy, 900, "integration")
