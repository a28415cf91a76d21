"""The memory checks' view of the machine, stubbed (memory_limit.py): no address-space limit,
no control group, `total` bytes of memory and no swap, this process holding `resident`."""


def machine_without_swap(monkeypatch, total, resident):
    import resource
    from surfgrad_addon.addon import memory_limit as ML
    monkeypatch.setattr(resource, "getrlimit", lambda _: (resource.RLIM_INFINITY,) * 2)
    monkeypatch.setattr(ML, "resident_in_use", lambda: resident)
    monkeypatch.setattr(ML, "_kb_line", lambda path, key: {"MemTotal": total,
                                                           "SwapTotal": 0}.get(key))
    monkeypatch.setattr(ML, "CGROUP_LIMITS", ())
