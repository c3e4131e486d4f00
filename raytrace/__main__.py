from raytrace.cli.command import main

main()
